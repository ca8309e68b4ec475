//! Helpers shared by the integration tests.

/// Declares tests that run on both targets: natively under `cargo test` and in headless
/// Chromium under `cargo test --target wasm32-unknown-unknown` (wasm-bindgen-test).
/// Each test is written once:
///
/// ```ignore
/// both_targets! {
///     /// What the test shows.
///     fn name() { ... }
/// }
/// ```
///
/// A file that uses it also says `wasm_bindgen_test_configure!(run_in_browser)` (or
/// `run_in_dedicated_worker`) once.
macro_rules! both_targets {
    ($($(#[$meta:meta])* fn $name:ident() $body:block)*) => {
        $(
            $(#[$meta])*
            #[cfg_attr(not(target_arch = "wasm32"), test)]
            #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
            fn $name() $body
        )*
    };
}
