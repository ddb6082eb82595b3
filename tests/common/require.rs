//! What a test needs that a checkout may lack: `../shared` beside it (the project's shared
//! scenes and references) and the Embree backend. [`skip_or_fail`] alone decides what a test
//! does when one is missing:
//!
//! - on CI (`CI=true`, as CI services set it): the test panics with the reason, so that CI
//!   cannot pass by testing nothing;
//! - elsewhere: it prints "skipping: …" and the test returns (passes).
//!
//! A build without Embree *on purpose* (`PIR_NO_EMBREE=1`, seen by the build script, which
//! then sets `cfg(pir_no_embree)`) is not a missing Embree: its Embree tests skip on CI too.

use std::path::PathBuf;

/// Whether this run is on CI: `CI` is set to `true`.
pub fn on_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v.trim().eq_ignore_ascii_case("true"))
}

/// Called when something a test needs is missing: panics on CI, else prints why the test
/// skips. The caller returns (skips) after it.
pub fn skip_or_fail(missing: &str) {
    if on_ci() {
        panic!("{missing}, and CI=true: CI must run this test, not skip it");
    }
    eprintln!("skipping: {missing}");
}

/// `../shared` beside the checkout, or `None` after [`skip_or_fail`] (for `test`, which names
/// the test or case in the message).
pub fn shared_dir(test: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared");
    if p.is_dir() {
        return Some(p);
    }
    skip_or_fail(&format!("{test}: ../shared is absent ({})", p.display()));
    None
}

/// Whether pir was built with Embree; when not, for `test`: a skip message if that was on
/// purpose (`PIR_NO_EMBREE=1`), else [`skip_or_fail`].
pub fn embree_available(test: &str) -> bool {
    if pir::accel::Backend::Embree.is_available() {
        return true;
    }
    let status = pir::accel::embree_status();
    if cfg!(pir_no_embree) {
        eprintln!("skipping: {test}: built without Embree on purpose ({status})");
    } else {
        skip_or_fail(&format!("{test}: pir was built without Embree ({status})"));
    }
    false
}
