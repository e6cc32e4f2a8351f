//! The scenes compiled into the binary, from `assets/scenes/`.

/// `(name, TOML text)` of every built-in scene.
pub const BUILTIN: &[(&str, &str)] = &[
    ("cantilever", include_str!("../../assets/scenes/cantilever.toml")),
    ("v-beam", include_str!("../../assets/scenes/v-beam.toml")),
    ("creature", include_str!("../../assets/scenes/creature.toml")),
    ("hanging-sheet", include_str!("../../assets/scenes/hanging-sheet.toml")),
    ("drape", include_str!("../../assets/scenes/drape.toml")),
    ("drape-quad", include_str!("../../assets/scenes/drape-quad.toml")),
    ("spin", include_str!("../../assets/scenes/spin.toml")),
    ("sweep", include_str!("../../assets/scenes/sweep.toml")),
    ("table", include_str!("../../assets/scenes/table.toml")),
    ("balloon", include_str!("../../assets/scenes/balloon.toml")),
    ("beams-steered", include_str!("../../assets/scenes/beams-steered.toml")),
    ("dancer", include_str!("../../assets/scenes/dancer.toml")),
    ("pbd-drape", include_str!("../../assets/scenes/pbd-drape.toml")),
    ("pile", include_str!("../../assets/scenes/pile.toml")),
    ("push", include_str!("../../assets/scenes/push.toml")),
    ("flag", include_str!("../../assets/scenes/flag.toml")),
    ("trampoline", include_str!("../../assets/scenes/trampoline.toml")),
];

/// Names of the built-in scenes, in order.
pub fn builtin_names() -> Vec<&'static str> {
    BUILTIN.iter().map(|(n, _)| *n).collect()
}
