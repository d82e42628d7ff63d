//! The library's front door: a scene file parsed ([`SceneFile`]), compiled with its
//! acceleration structure into a [`Renderer`], rendered with [`RenderSettings`] into a
//! [`Film`].

use crate::accel::{Accel, AccelKind};
use crate::adaptive::{Adaptive, PassProgress, Stop};
use crate::budget::Budget;
use crate::camera::{CameraPose, Lens};
use crate::error::Result;
use crate::farm::part::{self, Part, PixelSettings};
use crate::farm::region::{Region, TILE};
use crate::film::Film;
use crate::integrator::RayCounts;
use crate::progressive::{self, Progressive};
use crate::render::{self, Rendered};
use crate::scene::desc::{ObjectDesc, SceneDesc};
use crate::scene::{builtin, compile_within, mesh, Overrides, Scene, SceneSource};
use crate::settings::RenderSettings;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// A scene file, read and parsed: its TOML syntax and keys are checked (errors name the
/// line and column), its values are not yet (that is [`Renderer::new`]'s job). The keys
/// are documented in `scenes/README.md`.
#[derive(Debug)]
pub struct SceneFile {
    source: SceneSource,
    desc: SceneDesc,
}

impl SceneFile {
    /// Parse scene text. Mesh paths in it are relative to the current directory.
    pub fn from_toml(text: &str) -> Result<Self> {
        Self::parse(SceneSource::from_text(text, Path::new(".")))
    }

    /// Read and parse a scene file. Mesh paths in it are relative to its directory.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self> {
        Self::parse(SceneSource::read(path.as_ref())?)
    }

    /// One of the built-in scenes ([`SceneFile::builtin_names`]), embedded in the library
    /// with its meshes; [`Error::UnknownScene`](crate::Error::UnknownScene) lists them for
    /// any other name.
    pub fn builtin(name: &str) -> Result<Self> {
        Self::parse(SceneSource::builtin(name)?)
    }

    /// The names of the built-in scenes.
    pub fn builtin_names() -> Vec<&'static str> {
        builtin::names()
    }

    fn parse(source: SceneSource) -> Result<Self> {
        let desc = source.parse()?;
        Ok(Self { source, desc })
    }

    /// The scene's name: a built-in name or the file's stem (`scene` for text).
    pub fn name(&self) -> &str {
        &self.source.name
    }

    /// The scene file's one-line `description`.
    pub fn description(&self) -> &str {
        &self.desc.description
    }

    /// The files a render of this scene reads besides the scene file, each with what it
    /// is: its meshes' OBJ files (`"mesh"`), and the material libraries their `mtllib`
    /// lines name (`"material library"`, never read, but part of the mesh). None for a
    /// built-in scene, whose meshes are embedded. What no output of the run may replace.
    pub fn input_files(&self) -> Vec<(&'static str, PathBuf)> {
        let Some(dir) = &self.source.dir else {
            return Vec::new();
        };
        let mut files = Vec::new();
        let objects = self.desc.objects.iter().filter_map(|o| match o.get_ref() {
            ObjectDesc::Mesh { path, .. } => Some(path),
            _ => None,
        });
        let meshes = self.desc.meshes.values().map(|m| &m.get_ref().path);
        for path in objects.chain(meshes) {
            let obj = dir.join(path);
            let libraries = mesh::material_libraries(&obj);
            files.push(("mesh", obj));
            files.extend(libraries.into_iter().map(|l| ("material library", l)));
        }
        files
    }
}

/// How a scene is compiled: values that replace the scene file's, the acceleration
/// structure to build, and the memory it may take.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneOptions {
    /// Image width in pixels (1 to 65536); the height follows the scene's aspect ratio.
    pub width: Option<u32>,
    /// Samples per pixel (1 to 2^20).
    pub spp: Option<u32>,
    /// Maximum path depth (1 to 10000).
    pub max_depth: Option<u32>,
    /// The acceleration structure: the BVH by default.
    pub accel: AccelKind,
    /// The bytes the scene, its acceleration structure and the image may take; `None`:
    /// the machine's available memory (where the system says, else no limit). A scene
    /// estimated to need more is refused with
    /// [`Error::OutOfMemory`](crate::Error::OutOfMemory) before the memory is taken.
    pub max_memory: Option<u64>,
}

/// A compiled scene and the acceleration structure built over it, ready to render any
/// number of times.
///
/// Compiling checks every value (errors name the line of the scene file), turns boxes into
/// quads and meshes into triangles, and lays primitives out one pool per kind; the
/// acceleration structure then reorders those pools, which is why the two are built, and
/// kept, together.
#[derive(Debug)]
pub struct Renderer {
    scene: Scene,
    accel: Accel,
    build_time: Duration,
    /// `part::scene_digest`, taken by the first part rendered.
    digest: OnceLock<String>,
    /// The camera's place, as the scene file gave it or as last set.
    pose: CameraPose,
    /// The image size the scene was compiled (and its memory checked) for.
    built_size: (u32, u32),
}

impl Renderer {
    /// Compile `file` with `options` and build its acceleration structure, within the
    /// memory `options` allows: the image, the geometry and the trees are estimated
    /// before each is made (a mesh before it is read and before it is subdivided, the
    /// trees before the build).
    pub fn new(file: &SceneFile, options: &SceneOptions) -> Result<Self> {
        let overrides = Overrides {
            width: options.width,
            spp: options.spp,
            max_depth: options.max_depth,
        };
        let budget = options.max_memory.map_or_else(Budget::machine, Budget::cap);
        let mut scene = compile_within(&file.source, &file.desc, overrides, budget)?;
        let bvh = options.accel == AccelKind::Bvh;
        budget.check(
            &scene.memory_estimate(bvh),
            &format!(
                "{}: a {}x{} image and {} primitives",
                file.source.display,
                scene.camera.width,
                scene.camera.height,
                scene.primitive_count()
            ),
        )?;
        let start = Instant::now();
        let accel = Accel::build(&mut scene, options.accel);
        let default_camera = crate::scene::desc::CameraDesc::default();
        let cam = file
            .desc
            .camera
            .as_ref()
            .map_or(&default_camera, |c| c.get_ref());
        let lens =
            |v: &Option<toml::Spanned<f64>>, default| v.as_ref().map_or(default, |v| *v.get_ref());
        let pose = CameraPose {
            look_from: cam.look_from.0,
            look_at: cam.look_at.0,
            up: cam.up.0,
            vfov: cam.vfov,
            defocus_angle: lens(&cam.defocus_angle, Lens::PINHOLE.defocus_angle),
            focus_dist: lens(&cam.focus_dist, Lens::PINHOLE.focus_dist),
        };
        let built_size = (scene.camera.width, scene.camera.height);
        Ok(Self {
            scene,
            accel,
            build_time: start.elapsed(),
            digest: OnceLock::new(),
            pose,
            built_size,
        })
    }

    /// [`Renderer::new`] for scene text at the scene's own settings.
    pub fn from_toml(text: &str) -> Result<Self> {
        Self::new(&SceneFile::from_toml(text)?, &SceneOptions::default())
    }

    /// The scene's name ([`SceneFile::name`]).
    pub fn name(&self) -> &str {
        &self.scene.name
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.scene.camera.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.scene.camera.height
    }

    /// Samples per pixel.
    pub fn spp(&self) -> u32 {
        self.scene.spp
    }

    /// The time the acceleration structure took to build.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Render on the current rayon thread pool (the global one unless called inside
    /// `ThreadPool::install`). The film is the same bits for any number of threads.
    pub fn render(&self, settings: &RenderSettings) -> Result<Film> {
        Ok(self.render_with_progress(settings, &|| {})?.film)
    }

    /// [`Renderer::render`], calling `on_tile` after each tile of 16x16 pixels (from any
    /// thread), and counting the rays traced.
    pub fn render_with_progress(
        &self,
        settings: &RenderSettings,
        on_tile: &(dyn Fn() + Sync),
    ) -> Result<Rendered> {
        render::render(&self.scene, &self.accel, settings, on_tile)
    }

    /// Tiles a render calls `on_tile` for.
    pub fn tiles(&self) -> u32 {
        self.width().div_ceil(TILE) * self.height().div_ceil(TILE)
    }

    /// Render only the pixels of `region`, to write as a part file and merge with the
    /// frame's other parts ([`merge_parts`](crate::merge_parts)); each pixel has the bits
    /// of the same pixel of [`Renderer::render`] with the same settings.
    /// [`Error::Options`](crate::Error::Options) for a region outside the image.
    ///
    /// ```
    /// use raytracer::{merge_parts, Region, RenderSettings, Renderer};
    ///
    /// let renderer = Renderer::from_toml(r#"
    ///     background = [0.6, 0.7, 0.9]
    ///     camera = { width = 40, aspect_ratio = 2.0, samples_per_pixel = 2 }
    ///     materials.grey = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
    ///     objects = [{ type = "sphere", center = [0, 0, -2], radius = 0.5, material = "grey" }]
    /// "#)?;
    /// let settings = RenderSettings::default();
    /// let dir = std::env::temp_dir().join(format!("raytracer-parts-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir)?;
    /// let mut files = Vec::new();
    /// for index in 0..3 {
    ///     let part = renderer.render_part(&settings, Region::Part { index, count: 3 })?;
    ///     let file = dir.join(format!("part-{index}.part"));
    ///     part.write(&file)?;
    ///     files.push(file);
    /// }
    /// let merged = merge_parts(&files)?;
    /// assert_eq!(merged.film, renderer.render(&settings)?);
    /// # std::fs::remove_dir_all(&dir)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn render_part(&self, settings: &RenderSettings, region: Region) -> Result<Part> {
        self.render_part_with_progress(settings, region, &|| {})
    }

    /// [`Renderer::render_part`], calling `on_tile` after each tile (from any thread).
    pub fn render_part_with_progress(
        &self,
        settings: &RenderSettings,
        region: Region,
        on_tile: &(dyn Fn() + Sync),
    ) -> Result<Part> {
        let rendered = render::render_region(&self.scene, &self.accel, settings, region, on_tile)?;
        Ok(Part::new(
            rendered,
            self.name(),
            self.digest.get_or_init(|| part::scene_digest(&self.scene)),
            PixelSettings::new(&self.scene, settings, None),
        ))
    }

    /// Render adaptively ([`Adaptive`]): passes that double the samples of the tiles
    /// whose estimated error is above the target, until every tile reaches it or
    /// `max_spp`, or the passes run out. `on_tile` is called after each tile of each
    /// pass (from any thread), `on_pass` after each pass with the estimate so far; its
    /// `Break` ends the render there (the outcome records the passes, which reproduce
    /// the image as [`Adaptive::passes`]). The film is the same bits for any number of
    /// threads, packet width and region split.
    pub fn render_adaptive(
        &self,
        settings: &RenderSettings,
        adaptive: &Adaptive,
        on_tile: &(dyn Fn() + Sync),
        on_pass: &mut dyn FnMut(&PassProgress) -> ControlFlow<()>,
    ) -> Result<Rendered> {
        render::render_adaptive(
            &self.scene,
            &self.accel,
            settings,
            adaptive,
            on_tile,
            on_pass,
        )
    }

    /// [`Renderer::render_part`] with [`Renderer::render_adaptive`]'s sampling. The part
    /// file records the adaptive settings and the passes run, so that parts merge only
    /// with parts of the same settings.
    pub fn render_part_adaptive(
        &self,
        settings: &RenderSettings,
        adaptive: &Adaptive,
        region: Region,
        on_tile: &(dyn Fn() + Sync),
        on_pass: &mut dyn FnMut(&PassProgress) -> ControlFlow<()>,
    ) -> Result<Part> {
        let rendered = render::render_region_sampled(
            &self.scene,
            &self.accel,
            settings,
            region,
            render::Sampling::Adaptive(adaptive, on_pass),
            on_tile,
        )?;
        let outcome = rendered.adaptive.as_ref();
        // A render its caller cut short records its passes: the image is theirs.
        let recorded = Adaptive {
            passes: match outcome.map(|o| o.stop) {
                Some(Stop::Passes) => outcome.map(|o| o.passes),
                _ => adaptive.passes,
            },
            ..*adaptive
        };
        Ok(Part::new(
            rendered,
            self.name(),
            self.digest.get_or_init(|| part::scene_digest(&self.scene)),
            PixelSettings::new(&self.scene, settings, Some(&recorded)),
        ))
    }

    /// Path depth: the most bounces a path takes.
    pub fn max_depth(&self) -> u32 {
        self.scene.max_depth
    }

    /// Where the camera stands and how it sees.
    pub fn camera_pose(&self) -> CameraPose {
        self.pose
    }

    /// Move the camera: every later render sees the scene from `pose`, as a scene file
    /// with that pose in its `[camera]` table ([`Renderer::camera_toml`]) renders it, to
    /// the bit. A pose the scene file could not hold (`look_from` equal to `look_at`, a
    /// `vfov` outside 0 to 180 degrees, a camera too far for f32 rays) is
    /// [`Error::Options`](crate::Error::Options), and the camera stays where it was.
    pub fn set_camera_pose(&mut self, pose: &CameraPose) -> Result<()> {
        let camera = crate::scene::checked_camera(self.width(), self.height(), pose)
            .map_err(|(_, msg)| crate::Error::Options(msg))?;
        self.scene.camera = camera;
        self.pose = *pose;
        // A part file names the scene's digest, which covers the camera.
        self.digest = OnceLock::new();
        Ok(())
    }

    /// Render at `width` x `height` pixels from now on, with the same pose and field of
    /// view (a smaller picture of the same view, for a preview while the camera moves).
    /// [`Error::Options`](crate::Error::Options) for a size outside 1 to 65536 a side
    /// or larger than the image the renderer was built for (its memory was checked for
    /// that), or a camera that size cannot hold; the size stays as it was.
    pub fn set_size(&mut self, width: u32, height: u32) -> Result<()> {
        let (w, h) = self.built_size;
        if !(1..=w).contains(&width) || !(1..=h).contains(&height) {
            return Err(crate::Error::Options(format!(
                "image size {width}x{height}: at least 1x1 and at most the {w}x{h} the renderer was built for"
            )));
        }
        let camera = crate::scene::checked_camera(width, height, &self.pose)
            .map_err(|(_, msg)| crate::Error::Options(msg))?;
        self.scene.camera = camera;
        self.digest = OnceLock::new();
        Ok(())
    }

    /// The `[camera]` table that renders this camera, at this size, samples a pixel and
    /// depth ([`CameraPose::to_toml`]): pasted into the scene file in place of its own,
    /// the file renders what this renderer renders.
    pub fn camera_toml(&self) -> String {
        self.pose
            .to_toml(self.width(), self.height(), self.spp(), self.max_depth())
    }

    /// A progressive render of up to `spp` passes of one sample a pixel: its sums start
    /// black, and each [`Renderer::render_pass`] adds a pass. `spp` only matters to the
    /// stratified sampler, which spreads a pixel's draws over it.
    ///
    /// After N passes the film is the bits of [`Renderer::render`] at N samples a pixel,
    /// with the same settings:
    ///
    /// ```
    /// use raytracer::{RenderSettings, Renderer, SceneFile, SceneOptions};
    ///
    /// let file = SceneFile::from_toml(r#"
    ///     camera = { width = 24, aspect_ratio = 1.5 }
    ///     materials.red = { type = "phong", albedo = [0.8, 0.1, 0.1], shininess = 10 }
    ///     materials.lamp = { type = "light", color = [1, 1, 1] }
    ///     objects = [
    ///         { type = "sphere", center = [0, 0, -2], radius = 0.5, material = "red" },
    ///         { type = "sphere", center = [1, 1, -1], radius = 0.1, material = "lamp" },
    ///     ]
    /// "#)?;
    /// let settings = RenderSettings::default();
    /// let renderer = Renderer::new(&file, &SceneOptions::default())?;
    /// let mut progressive = renderer.progressive(64)?;
    /// for _ in 0..3 {
    ///     renderer.render_pass(&settings, &mut progressive)?;
    /// }
    /// let three = SceneOptions { spp: Some(3), ..Default::default() };
    /// assert_eq!(progressive.film()?, Renderer::new(&file, &three)?.render(&settings)?);
    /// # Ok::<(), raytracer::Error>(())
    /// ```
    pub fn progressive(&self, spp: u32) -> Result<Progressive> {
        Progressive::new(self.width(), self.height(), spp)
    }

    /// Render the next pass of `progressive`: sample `progressive.passes()` of every
    /// pixel, added to its sum, on the current rayon pool; the rays it traced. After the
    /// camera moves, [`Progressive::restart`] starts again from sample 0.
    /// [`Error::Options`](crate::Error::Options) for a render of another image size,
    /// with all its passes, or interrupted ([`Renderer::render_pass_unless`]).
    pub fn render_pass(
        &self,
        settings: &RenderSettings,
        progressive: &mut Progressive,
    ) -> Result<RayCounts> {
        let counts =
            progressive::render_pass(&self.scene, &self.accel, settings, progressive, &|| false)?;
        Ok(counts.unwrap_or_default())
    }

    /// [`Renderer::render_pass`], unless `stop` says yes: it is asked before each tile
    /// of 16x16 pixels (from any thread), and once it does, the tiles not yet begun are
    /// skipped and the pass is `None`, not counted. Then the tiles differ in samples
    /// ([`Progressive::is_interrupted`]) and only [`Progressive::restart`] continues the
    /// render: for a pass that a camera move makes useless.
    ///
    /// ```
    /// use raytracer::{RenderSettings, Renderer};
    /// use std::sync::atomic::{AtomicU32, Ordering};
    ///
    /// let renderer = Renderer::from_toml(r#"
    ///     camera = { width = 64, aspect_ratio = 1.0 }
    ///     materials.grey = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
    ///     objects = [{ type = "sphere", center = [0, 0, -2], radius = 0.5, material = "grey" }]
    /// "#)?;
    /// let settings = RenderSettings::default();
    /// let mut progressive = renderer.progressive(16)?;
    /// // 16 tiles; stop after the fifth has begun (on one thread).
    /// let begun = AtomicU32::new(0);
    /// let stop = || begun.fetch_add(1, Ordering::Relaxed) >= 5;
    /// let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    /// let pass = pool.install(|| renderer.render_pass_unless(&settings, &mut progressive, &stop))?;
    /// assert!(pass.is_none() && progressive.is_interrupted());
    /// assert_eq!(progressive.passes(), 0);
    /// assert!(renderer.render_pass(&settings, &mut progressive).is_err());
    /// progressive.restart();
    /// renderer.render_pass(&settings, &mut progressive)?;
    /// assert_eq!(progressive.passes(), 1);
    /// # Ok::<(), raytracer::Error>(())
    /// ```
    pub fn render_pass_unless(
        &self,
        settings: &RenderSettings,
        progressive: &mut Progressive,
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<RayCounts>> {
        progressive::render_pass(&self.scene, &self.accel, settings, progressive, stop)
    }

    /// The compiled scene, for the command line's statistics and the tests.
    #[doc(hidden)]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The acceleration structure, for the command line's statistics and the tests.
    #[doc(hidden)]
    pub fn accel(&self) -> &Accel {
        &self.accel
    }
}
