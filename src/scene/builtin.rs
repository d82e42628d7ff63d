//! The built-in scenes and the assets they use, embedded in the binary so that a scene
//! name works from any working directory.

/// (name, scene file text). Names are the file stems in `scenes/`.
pub const SCENES: &[(&str, &str)] = &[
    ("bunny", include_str!("../../scenes/bunny.toml")),
    (
        "bunny-closeup",
        include_str!("../../scenes/bunny-closeup.toml"),
    ),
    ("cornell", include_str!("../../scenes/cornell.toml")),
    (
        "cornell-area-light",
        include_str!("../../scenes/cornell-area-light.toml"),
    ),
    (
        "cornell-point-light",
        include_str!("../../scenes/cornell-point-light.toml"),
    ),
    ("mixed", include_str!("../../scenes/mixed.toml")),
    ("quads", include_str!("../../scenes/quads.toml")),
    ("spheres", include_str!("../../scenes/spheres.toml")),
    (
        "spheres-defocus",
        include_str!("../../scenes/spheres-defocus.toml"),
    ),
];

/// (path as the built-in scene files write it, text).
pub const ASSETS: &[(&str, &str)] = &[(
    "../assets/bunny.obj",
    include_str!("../../assets/bunny.obj"),
)];

pub fn scene(name: &str) -> Option<&'static str> {
    SCENES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

pub fn asset(path: &str) -> Option<&'static str> {
    ASSETS.iter().find(|(p, _)| *p == path).map(|(_, t)| *t)
}

pub fn names() -> Vec<&'static str> {
    SCENES.iter().map(|(n, _)| *n).collect()
}
