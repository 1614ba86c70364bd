//! Snapshots of the exported HLSL, MSL and engine includes of every built-in scene (issue 13:
//! the outputs no validator on this machine compiles are pinned instead).
//!
//! The texts are a pure function of the scene, the emitter and the pinned naga, so any change
//! here is a change every Unity, Unreal, Godot or Metal client receives: a renamed function, a
//! moved uniform, a different constant. A failing snapshot shows the diff. If the change is
//! meant, re-mint with `INSTA_UPDATE=always cargo test --test shader_snapshots` (or
//! `cargo insta review`), read the diff of `tests/snapshots/`, and say in the commit what
//! clients will see differ (a changed interface also wants a note in `docs/clients.md`).
//!
//! insta fails the assertion on any difference, whatever `INSTA_UPDATE` says short of
//! `always`; under `CI=true` (how CI runs `.ci/run`) it also writes no `.snap.new` files, so
//! CI fails on a changed or missing snapshot and leaves the tree clean.

use swell::scene::{Scene, builtin};
use swell_shaders::Lang;

/// Every built-in scene in `lang` (all entry points), one snapshot each: `{scene}.{lang}`
/// (the FFT scenes' engine includes too: they declare the FFT layers' result textures).
fn snapshot_builtins(lang: Lang) {
    let specs = builtin::specs();
    assert!(specs.len() >= 5, "the built-in scenes are all here");
    for (id, spec) in specs {
        let scene = Scene::build(&id, spec).unwrap();
        let text = swell_shaders::export(&scene.surface, lang, None)
            .unwrap_or_else(|e| panic!("{id} {lang:?}: {e}"));
        insta::with_settings!({ omit_expression => true, prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!(format!("{id}.{}", lang.name()), text);
        });
    }
}

#[test]
fn hlsl_of_every_builtin_scene() {
    snapshot_builtins(Lang::Hlsl);
}

#[test]
fn msl_of_every_builtin_scene() {
    snapshot_builtins(Lang::Msl);
}

#[test]
fn hlsl_include_of_every_builtin_scene() {
    snapshot_builtins(Lang::HlslInclude);
}

#[test]
fn gdshaderinc_of_every_builtin_scene() {
    snapshot_builtins(Lang::Gdshaderinc);
}
