//! Writing images: PNG (8-bit), binary PPM (P6) or OpenEXR (linear f32 RGB, the film's
//! values bit for bit), chosen by the file extension.
//!
//! All or nothing: the files of a run (the image, the report) are written together by an
//! `OutputSet`: each to a temporary file beside its target, all flushed and checked, then
//! renamed into place one after the other, an earlier rename undone if a later one
//! fails. A failed run never leaves a half-written, clobbered or lone file.
//!
//! Temporary files are named `.raytracer-PID-XXXXXX.tmp` (`.old` for the copy of a file
//! being replaced) and registered while they exist: `install_signal_cleanup` removes
//! them on SIGINT and SIGTERM, then lets the signal end the process. SIGKILL cannot be
//! caught; what it leaves carries the dead process's id, and `remove_stale_temporaries`
//! removes such files once no process has that id.
//!
//! One file past 700 lines (230 of them tests): the encoders and the atomic, cleaned-up
//! writing of their files are one guarantee (never a half-written or stray file).

use crate::error::{Error, Result};
use crate::film::Film;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Ppm,
    /// OpenEXR, linear f32 RGB: no gamma, no clamp, no quantisation.
    Exr,
}

impl ImageFormat {
    /// The format for a path's extension; checked before rendering starts.
    pub fn for_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("ppm") => Ok(ImageFormat::Ppm),
            Some("exr") => Ok(ImageFormat::Exr),
            _ => Err(Error::Output {
                path: path.to_path_buf(),
                message: "unsupported image format (use .png or .ppm, or .exr for linear f32)"
                    .into(),
            }),
        }
    }
}

/// Gamma 2 (square root) and truncation to 8 bits, as the original program does; values
/// are clamped to [0, 1] first (the original program wrote values above 1 past the PPM
/// maximum) and NaN becomes 0.
#[inline]
pub fn quantize(c: f32) -> u8 {
    let c = if c > 0.0 { c.min(1.0) } else { 0.0 };
    (255.999 * c.sqrt()) as u8
}

impl Film {
    /// 8-bit RGB bytes, row by row, as PNG and PPM files hold them: each channel clamped
    /// to [0, 1] (NaN as 0), gamma 2 (its square root), then truncated ([`quantize`]), as
    /// the original program wrote them.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| [quantize(p.x), quantize(p.y), quantize(p.z)])
            .collect()
    }

    /// Write the film to `path`: `.png` or `.ppm` (8-bit, [`Film::to_rgb8`]) or `.exr`
    /// (linear f32, bit for bit), chosen by the extension. The file is written to a
    /// temporary file beside it and renamed into place, so a failure never leaves a
    /// partial file or clobbers an existing one.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        write_image(self, path.as_ref())
    }
}

/// Write the film to `path` (format by extension), atomically.
pub fn write_image(film: &Film, path: &Path) -> Result<()> {
    let mut set = OutputSet::default();
    set.add_image(film, path)?;
    set.commit()
}

/// Write the film as OpenEXR with three f32 channels (linear RGB), atomically.
pub fn write_exr(film: &Film, path: &Path) -> Result<()> {
    write_image(film, path)
}

/// Encode the film in `format` to `out`, with no second full-size copy of the image (the
/// write costs the film's 12 bytes a pixel and buffers of a few rows): PNG and PPM are
/// quantised a row at a time; EXR is written by the `exr` crate a 64x64 tile at a time
/// (run-length encoded, as `image` writes it), reading the film's pixels as it goes.
fn encode<W: Write + std::io::Seek>(
    film: &Film,
    format: ImageFormat,
    out: &mut W,
) -> std::io::Result<()> {
    match format {
        ImageFormat::Exr => encode_exr(film, out),
        rows => encode_rows(film, rows, out),
    }
}

/// Encode the film in `format` to a stream (standard output, a pipe): PNG and PPM as
/// they are made; EXR, whose writer goes back to fill in its table of offsets, whole in
/// memory first (about 12 bytes a pixel more than a file takes).
pub fn encode_to_stream(
    film: &Film,
    format: ImageFormat,
    out: &mut impl Write,
) -> std::io::Result<()> {
    match format {
        ImageFormat::Exr => {
            let mut buffer = std::io::Cursor::new(Vec::new());
            encode_exr(film, &mut buffer)?;
            out.write_all(buffer.get_ref())
        }
        rows => encode_rows(film, rows, out),
    }
}

/// PNG or PPM, quantised a row at a time.
fn encode_rows<W: Write>(film: &Film, format: ImageFormat, out: &mut W) -> std::io::Result<()> {
    let (w, h) = (film.width, film.height);
    let rows = || {
        film.pixels.chunks_exact(w.max(1) as usize).map(|row| {
            row.iter()
                .flat_map(|p| [quantize(p.x), quantize(p.y), quantize(p.z)])
                .collect::<Vec<u8>>()
        })
    };
    match format {
        ImageFormat::Ppm => {
            write!(out, "P6\n{w} {h}\n255\n")?;
            rows().try_for_each(|row| out.write_all(&row))
        }
        ImageFormat::Png => {
            // The `image` crate's PNG settings: fast compression, adaptive filters.
            let mut encoder = png::Encoder::new(&mut *out, w, h);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_compression(png::Compression::Fast);
            encoder.set_filter(png::Filter::Adaptive);
            let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
            let mut stream = writer.stream_writer().map_err(std::io::Error::other)?;
            rows().try_for_each(|row| stream.write_all(&row))?;
            stream.finish().map_err(std::io::Error::other)?;
            writer.finish().map_err(std::io::Error::other)
        }
        ImageFormat::Exr => unreachable!("EXR is not written row by row"),
    }
}

/// OpenEXR, written by the `exr` crate a 64x64 tile at a time.
fn encode_exr<W: Write + std::io::Seek>(film: &Film, out: &mut W) -> std::io::Result<()> {
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    let width = film.width as usize;
    let channels = SpecificChannels::rgb(|at: Vec2<usize>| {
        let p = film.pixels[at.y() * width + at.x()];
        (p.x, p.y, p.z)
    });
    Image::from_channels((width, film.height as usize), channels)
        .write()
        .non_parallel()
        .to_buffered(out)
        .map_err(|e| match e {
            exr::error::Error::Io(io) => io,
            other => std::io::Error::other(other),
        })
}

/// Read an OpenEXR image (any channel layout `image` can decode) into a film of linear
/// RGB; f32 channels come back bit for bit.
pub fn read_exr(path: &Path) -> Result<Film> {
    let fail = |message: String| Error::Io {
        path: path.display().to_string(),
        source: std::io::Error::other(message),
    };
    // A device or FIFO given as a reference would be read forever, or block.
    crate::scene::input::check_file(path, u64::MAX, "reference image")
        .map_err(|e| fail(e.to_string()))?;
    let reader = image::ImageReader::open(path)
        .map_err(|e| fail(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| fail(e.to_string()))?;
    if reader.format() != Some(image::ImageFormat::OpenExr) {
        return Err(fail("not an OpenEXR file".into()));
    }
    let rgb = reader
        .decode()
        .map_err(|e| fail(e.to_string()))?
        .into_rgb32f();
    let (width, height) = rgb.dimensions();
    let pixels = rgb.pixels().map(|p| glam::Vec3::from_array(p.0)).collect();
    Ok(Film {
        width,
        height,
        pixels,
    })
}

/// Check, before a long render, that `path` can be written: its directory exists, it is
/// not a directory, and a file can be created beside it (the temporary file an
/// `OutputSet` writes: a read-only directory, or one without room for a new file, is
/// found here rather than after the render).
pub fn check_writable(path: &Path) -> Result<()> {
    let fail = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    let dir = parent_dir(path);
    match std::fs::metadata(dir) {
        Ok(meta) if meta.is_dir() => {}
        Ok(_) => return Err(fail(format!("{} is not a directory", dir.display()))),
        Err(e) => {
            // A file on the way (`afile/sub/out.png`) is named as what is wrong.
            let file = dir.ancestors().skip(1).find(|a| a.is_file());
            return Err(fail(match file {
                Some(file) => format!("{} is not a directory", file.display()),
                None if e.kind() == std::io::ErrorKind::NotFound => {
                    format!("directory {} does not exist", dir.display())
                }
                None => format!("cannot use directory {}: {e}", dir.display()),
            }));
        }
    }
    if path.is_dir() {
        return Err(fail("is a directory".into()));
    }
    // Registered like any temporary file, so a signal now leaves nothing behind.
    let probe = {
        let mut list = pending();
        let probe = tempfile::Builder::new()
            .prefix(&temp_prefix())
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(|e| {
                fail(format!(
                    "cannot create a file in {}: {}",
                    dir.display(),
                    e.kind()
                ))
            })?;
        list.push(probe.path().to_path_buf());
        probe
    };
    let written = probe
        .as_file()
        .write_all(b"0")
        .and_then(|()| probe.as_file().sync_all());
    {
        // Removed with the list locked: a signal finds it listed or gone.
        let mut list = pending();
        forget(&mut list, probe.path());
        drop(probe);
    }
    written.map_err(|e| fail(format!("cannot write a file in {}: {e}", dir.display())))?;
    Ok(())
}

/// The directory `path` is in (`.` for a bare file name): where its temporary files go.
pub fn directory_of(path: &Path) -> PathBuf {
    parent_dir(path).to_path_buf()
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Write through a temporary file in the same directory, then rename over `path`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut Checked) -> std::io::Result<()>,
) -> Result<()> {
    let mut set = OutputSet::default();
    set.add(path, write)?;
    set.commit()
}

/// The writer of an `OutputSet` file (buffered), which keeps the end of what was written
/// (an encoder may seek back to fill in a table), to check against the file's length.
#[derive(Debug)]
pub struct Checked<'f> {
    inner: std::io::BufWriter<&'f std::fs::File>,
    position: u64,
    end: u64,
}

impl Write for Checked<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.position += n as u64;
        self.end = self.end.max(self.position);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Seek for Checked<'_> {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        self.position = self.inner.seek(to)?;
        Ok(self.position)
    }
}

/// Temporary files that exist now (written, or copies of files being replaced): what a
/// signal's cleanup removes. Locked for the whole of a commit's renames and of the
/// cleanup, so a signal finds either no file renamed or all of them.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic while holding the lock leaves a list that is still right.
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

fn forget(list: &mut Vec<PathBuf>, path: &Path) {
    list.retain(|p| p != path);
}

/// The prefix of this process's temporary files.
fn temp_prefix() -> String {
    format!(".raytracer-{}-", std::process::id())
}

/// Files written together: each to a temporary file beside its target, then, by
/// `commit`, all renamed into place. Dropped without a commit, it removes its temporary
/// files and no target changes.
#[derive(Debug, Default)]
pub struct OutputSet {
    /// (temporary file, target); the temporary file is removed when dropped.
    files: Vec<(tempfile::TempPath, PathBuf)>,
}

impl OutputSet {
    /// Write `path`'s contents to a temporary file in its directory, flushed to disk, and
    /// check its length against what was written.
    pub fn add(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut Checked) -> std::io::Result<()>,
    ) -> Result<()> {
        let fail = |e: std::io::Error| Error::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        if self.files.iter().any(|(_, p)| p == path) {
            return Err(fail(std::io::Error::other("written twice by one run")));
        }
        let tmp = {
            // Registered before it exists, so no signal can leave it behind.
            let mut list = pending();
            let tmp = tempfile::Builder::new()
                .prefix(&temp_prefix())
                .suffix(".tmp")
                .tempfile_in(parent_dir(path))
                .map_err(fail)?;
            list.push(tmp.path().to_path_buf());
            tmp
        };
        let (file, tmp) = tmp.into_parts();
        let result = (|| {
            // tempfile creates 0600; give the result the permissions of the file it
            // replaces, or the usual 0644 for a new file.
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let permissions = std::fs::metadata(path)
                    .map(|m| m.permissions())
                    .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644));
                file.set_permissions(permissions)?;
            }
            let mut out = Checked {
                inner: std::io::BufWriter::new(&file),
                position: 0,
                end: 0,
            };
            write(&mut out)?;
            out.flush()?;
            let written = out.end;
            drop(out);
            file.sync_all()?;
            let on_disk = file.metadata()?.len();
            if on_disk != written {
                return Err(std::io::Error::other(format!(
                    "the temporary file has {on_disk} bytes, {written} were written"
                )));
            }
            Ok(())
        })();
        if let Err(e) = result {
            forget(&mut pending(), &tmp);
            return Err(fail(e));
        }
        self.files.push((tmp, path.to_path_buf()));
        Ok(())
    }

    /// `add` the film as an image (format by the extension).
    pub fn add_image(&mut self, film: &Film, path: &Path) -> Result<()> {
        let format = ImageFormat::for_path(path)?;
        self.add(path, |out| encode(film, format, out))
    }

    /// Rename every file into place, in the order added. If a rename fails, the files
    /// renamed before it are put back as they were (a replaced file from a hard-linked
    /// copy made first; where the file system has no hard links, a replaced file cannot
    /// be put back) and the error names the file that failed.
    pub fn commit(self) -> Result<()> {
        let mut list = pending();
        // Copies of the targets that exist, to undo with (removed when dropped).
        let backups: Vec<Option<tempfile::TempPath>> = self
            .files
            .iter()
            .map(|(_, target)| {
                let copy = tempfile::Builder::new()
                    .prefix(&temp_prefix())
                    .suffix(".old")
                    .make_in(parent_dir(target), |p| std::fs::hard_link(target, p))
                    .ok()?;
                let (_, path) = copy.into_parts();
                list.push(path.to_path_buf());
                Some(path)
            })
            .collect();
        let mut done = 0;
        let mut failure = None;
        for (tmp, target) in &self.files {
            match std::fs::rename(tmp, target) {
                Ok(()) => {
                    forget(&mut list, tmp);
                    done += 1;
                }
                Err(e) => {
                    failure = Some(Error::Output {
                        path: target.clone(),
                        message: e.to_string(),
                    });
                    break;
                }
            }
        }
        if failure.is_some() {
            for ((_, target), backup) in self.files.iter().zip(&backups).take(done) {
                match backup {
                    Some(b) => {
                        let _ = std::fs::rename(b, target);
                    }
                    None => {
                        let _ = std::fs::remove_file(target);
                    }
                }
            }
        }
        for b in backups.iter().flatten() {
            forget(&mut list, b);
        }
        // The temporary files left (after a failure) are removed as `self` drops; the
        // renamed ones are gone already.
        drop(list);
        failure.map_or(Ok(()), Err)
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        let mut list = pending();
        for (tmp, _) in &self.files {
            forget(&mut list, tmp);
        }
    }
}

/// Remove every temporary file registered now; returns how many were removed. The
/// signal cleanup calls it with the list locked, so no commit is halfway.
pub fn remove_pending() -> usize {
    remove_locked(&mut pending())
}

fn remove_locked(list: &mut Vec<PathBuf>) -> usize {
    let removed = list
        .iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count();
    list.clear();
    removed
}

/// On SIGINT and SIGTERM, remove this process's temporary files (`remove_pending`), then
/// end the process by the signal's default action (so its parent sees the signal). A
/// thread waits for the signals (`signal-hook`: the handler itself only wakes it, which
/// is all a signal handler may safely do). Call once, early.
///
/// Also makes SIGXFSZ (a write past the file-size limit, `ulimit -f`) a failed write, an
/// error like a full disk, instead of the end of the process with its files left.
#[cfg(unix)]
pub fn install_signal_cleanup() -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM, SIGXFSZ};
    signal_hook::flag::register(SIGXFSZ, std::sync::Arc::default())?;
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    std::thread::Builder::new()
        .name("signal cleanup".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                let mut list = pending();
                remove_locked(&mut list);
                // Still holding the lock: no commit can start before the process ends.
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        })?;
    Ok(())
}

/// Temporary files that a process killed by SIGKILL left in `dir`: `.raytracer-PID-*`
/// whose process no longer exists (`/proc/PID` is gone). Removes them and returns their
/// paths. Files of running processes, and every other file, are left alone.
pub fn remove_stale_temporaries(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return Vec::new();
    }
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(rest) = name.strip_prefix(".raytracer-") else {
            continue;
        };
        let Some((pid, tail)) = rest.split_once('-') else {
            continue;
        };
        let ours = (tail.ends_with(".tmp") || tail.ends_with(".old"))
            && !pid.is_empty()
            && pid.bytes().all(|b| b.is_ascii_digit());
        if ours && !proc.join(pid).exists() && entry.file_type().is_ok_and(|t| t.is_file()) {
            let path = entry.path();
            if std::fs::remove_file(&path).is_ok() {
                removed.push(path);
            }
        }
    }
    removed
}

/// The report must not replace the image: `--report` naming it would overwrite it with
/// JSON. Paths are compared as the files they name (an existing file by device and inode,
/// so links are seen through; otherwise by absolute path).
pub fn check_distinct_outputs(image: &Path, report: &Path) -> Result<()> {
    if same_file(report, image) {
        return Err(Error::Output {
            path: report.to_path_buf(),
            message: format!("the report would overwrite the image {}", image.display()),
        });
    }
    Ok(())
}

/// An output must not replace a file the run reads: `output`, written for `flag`, is
/// refused if it is one of `inputs` (what each is, and its path), compared as files by
/// device and inode, so another name for the file (a hard or symbolic link, `./x`) is
/// seen through. An output that does not exist yet is no input.
pub fn check_not_an_input(flag: &str, output: &Path, inputs: &[(&str, &Path)]) -> Result<()> {
    let Ok(out) = std::fs::metadata(output) else {
        return Ok(());
    };
    for (what, input) in inputs {
        if std::fs::metadata(input).is_ok_and(|i| is_same(&out, &i, output, input)) {
            return Err(Error::Output {
                path: output.to_path_buf(),
                message: format!(
                    "{flag} names the {what} {}, which the run reads",
                    input.display()
                ),
            });
        }
    }
    Ok(())
}

/// Two existing files' metadata are one file's: device and inode where there are such
/// (Unix), else the same canonical path.
fn is_same(a: &std::fs::Metadata, b: &std::fs::Metadata, pa: &Path, pb: &Path) -> bool {
    #[cfg(unix)]
    {
        let _ = (pa, pb);
        use std::os::unix::fs::MetadataExt;
        a.dev() == b.dev() && a.ino() == b.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (a, b);
        matches!((pa.canonicalize(), pb.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

/// Do `a` and `b` name the same file (existing or not)?
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    let absolute = |p: &Path| -> Option<PathBuf> {
        let dir = parent_dir(p).canonicalize().ok()?;
        Some(dir.join(p.file_name()?))
    };
    match (absolute(a), absolute(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantize_clamps_and_takes_the_square_root() {
        assert_eq!(quantize(0.0), 0);
        assert_eq!(quantize(-1.0), 0);
        assert_eq!(quantize(f32::NAN), 0);
        assert_eq!(quantize(1.0), 255);
        assert_eq!(quantize(4.0), 255);
        assert_eq!(quantize(0.25), 127); // 255.999 · 0.5 = 127.99 → 127
        assert_eq!(quantize(0.01), 25); // 255.999 · 0.1 = 25.6 → 25
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        // Values a PNG would clamp or round away: above 1, tiny, negative zero, subnormal,
        // many mantissa bits, and a non-square size.
        let (width, height) = (5, 3);
        let values = [
            0.0,
            -0.0,
            1.0,
            17.25,
            1e-30,
            f32::MIN_POSITIVE / 4.0,
            0.1,
            std::f32::consts::PI,
            65504.5,
            1.0e10,
        ];
        let pixels = (0..width * height)
            .map(|i| {
                let v = |k: u32| values[((3 * i + k) as usize * 7) % values.len()];
                glam::Vec3::new(v(0), v(1) * 1.000_001, v(2) + i as f32 * 1e-3)
            })
            .collect();
        let film = Film {
            width,
            height,
            pixels,
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("film.exr");
        write_image(&film, &path).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (width, height));
        let bits = |f: &Film| -> Vec<u32> {
            f.pixels
                .iter()
                .flat_map(|p| p.to_array().map(f32::to_bits))
                .collect()
        };
        assert_eq!(bits(&back), bits(&film));
        // Only the image is left in the directory (the temporary file was renamed).
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// Names in `dir`, sorted.
    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_set_commits_all_its_files_or_none() {
        let dir = tempfile::tempdir().unwrap();
        let (image, report) = (dir.path().join("a.ppm"), dir.path().join("r.json"));
        std::fs::write(&image, b"old image").unwrap();
        let film = Film::new(2, 1).unwrap();
        // Both written.
        let mut set = OutputSet::default();
        set.add_image(&film, &image).unwrap();
        set.add(&report, |out| out.write_all(b"{}")).unwrap();
        assert_eq!(std::fs::read(&image).unwrap(), b"old image");
        set.commit().unwrap();
        assert_eq!(
            std::fs::read(&image).unwrap(),
            b"P6\n2 1\n255\n\0\0\0\0\0\0"
        );
        assert_eq!(std::fs::read(&report).unwrap(), b"{}");
        assert_eq!(names(dir.path()), ["a.ppm", "r.json"]);
        // The report's rename fails (a non-empty directory is in its place): the image
        // that was renamed first is put back, and no temporary file is left.
        std::fs::write(&image, b"old image").unwrap();
        std::fs::remove_file(&report).unwrap();
        std::fs::create_dir(&report).unwrap();
        std::fs::write(report.join("x"), b"").unwrap();
        let mut set = OutputSet::default();
        set.add_image(&film, &image).unwrap();
        set.add(&report, |out| out.write_all(b"{}")).unwrap();
        let e = set.commit().unwrap_err();
        assert!(e.to_string().contains("r.json"), "{e}");
        assert_eq!(std::fs::read(&image).unwrap(), b"old image");
        assert_eq!(names(dir.path()), ["a.ppm", "r.json"]);
        // A new image (no file to put back) is removed.
        std::fs::remove_file(&image).unwrap();
        let mut set = OutputSet::default();
        set.add_image(&film, &image).unwrap();
        set.add(&report, |out| out.write_all(b"{}")).unwrap();
        assert!(set.commit().is_err());
        assert_eq!(names(dir.path()), ["r.json"]);
        // Nothing of this directory is left to remove on a signal (other tests, running
        // in parallel, may have their own files pending).
        assert!(!pending().iter().any(|p| p.starts_with(dir.path())));
    }

    #[test]
    fn a_failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.json");
        let mut set = OutputSet::default();
        let e = set
            .add(&path, |out| {
                out.write_all(b"partial")?;
                Err(std::io::Error::other("disk full"))
            })
            .unwrap_err();
        assert!(e.to_string().contains("disk full"), "{e}");
        drop(set);
        assert!(names(dir.path()).is_empty());
        // An uncommitted set removes what it wrote.
        let mut set = OutputSet::default();
        set.add(&path, |out| out.write_all(b"{}")).unwrap();
        assert_eq!(names(dir.path()).len(), 1);
        drop(set);
        assert!(names(dir.path()).is_empty());
    }

    #[test]
    fn the_report_may_not_replace_the_image() {
        let dir = tempfile::tempdir().unwrap();
        let image = dir.path().join("out.png");
        let report = dir.path().join("r.json");
        assert!(check_distinct_outputs(&image, &report).is_ok());
        // The image does not exist yet: compared by absolute path.
        let again = dir.path().join(".").join("out.png");
        let e = check_distinct_outputs(&image, &again).unwrap_err();
        assert!(e.to_string().contains("the image"), "{e}");
    }

    #[test]
    fn an_output_may_not_be_an_input_by_any_name() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, b"x").unwrap();
        let inputs = [("scene file", scene.as_path())];
        let new = dir.path().join("out.png");
        assert!(check_not_an_input("-o", &new, &inputs).is_ok());
        let e = check_not_an_input("-o", &scene, &inputs).unwrap_err();
        assert!(e.to_string().contains("-o names the scene file"), "{e}");
        let again = dir.path().join(".").join("s.toml");
        assert!(check_not_an_input("-o", &again, &inputs).is_err());
        // A different file with the same contents is not the input.
        let copy = dir.path().join("copy.toml");
        std::fs::write(&copy, b"x").unwrap();
        assert!(check_not_an_input("-o", &copy, &inputs).is_ok());
        #[cfg(unix)]
        {
            let hard = dir.path().join("hard.png");
            std::fs::hard_link(&scene, &hard).unwrap();
            assert!(check_not_an_input("-o", &hard, &inputs).is_err());
            let link = dir.path().join("link.toml");
            std::os::unix::fs::symlink(&scene, &link).unwrap();
            assert!(check_not_an_input("--report", &link, &inputs).is_err());
        }
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        // No process has id 4294967295 (above Linux's pid_max).
        let dead = ".raytracer-4294967295-abc123.tmp";
        let dead_old = ".raytracer-4294967295-x.old";
        let ours = format!(".raytracer-{}-abc123.tmp", std::process::id());
        for name in [
            dead,
            dead_old,
            ours.as_str(),
            ".raytracer-x-1.tmp",
            "keep.png",
        ] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        let removed = remove_stale_temporaries(dir.path());
        if !Path::new("/proc/self").exists() {
            assert!(removed.is_empty());
            return;
        }
        assert_eq!(removed.len(), 2);
        let mut left = names(dir.path());
        left.retain(|n| n != &ours);
        assert_eq!(left, [".raytracer-x-1.tmp", "keep.png"]);
    }

    #[test]
    fn png_and_ppm_written_row_by_row_hold_the_quantised_film() {
        let (width, height) = (5, 3);
        let pixels = (0..width * height)
            .map(|i| glam::Vec3::new(i as f32 / 15.0, 1.0 - i as f32 / 15.0, (i % 4) as f32))
            .collect();
        let film = Film {
            width,
            height,
            pixels,
        };
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("f.png");
        write_image(&film, &png).unwrap();
        let decoded = image::open(&png).unwrap().into_rgb8();
        assert_eq!(decoded.dimensions(), (width, height));
        assert_eq!(decoded.into_raw(), film.to_rgb8());
        let ppm = dir.path().join("f.ppm");
        write_image(&film, &ppm).unwrap();
        let mut want = b"P6\n5 3\n255\n".to_vec();
        want.extend(film.to_rgb8());
        assert_eq!(std::fs::read(&ppm).unwrap(), want);
    }

    #[test]
    fn a_bad_reference_is_a_read_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ref.exr");
        std::fs::write(&path, b"not an image").unwrap();
        let chain = |e: Error| {
            let source = std::error::Error::source(&e).map(|s| s.to_string());
            format!("{e}: {}", source.unwrap_or_default())
        };
        let message = chain(read_exr(&path).unwrap_err());
        assert!(message.starts_with("cannot read"), "{message}");
        assert!(message.contains("OpenExr"), "{message}");
        // Named .png: the format is not EXR.
        let png = dir.path().join("ref.png");
        std::fs::write(&png, b"not an image").unwrap();
        let message = chain(read_exr(&png).unwrap_err());
        assert!(message.contains("not an OpenEXR file"), "{message}");
        let message = chain(read_exr(&dir.path().join("missing.exr")).unwrap_err());
        assert!(message.starts_with("cannot read"), "{message}");
        let message = chain(read_exr(dir.path()).unwrap_err());
        assert!(message.contains("not a regular file"), "{message}");
    }
}
