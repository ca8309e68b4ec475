//! Sets `cfg(parallel)` where the pipeline's stages may run on rayon's pool: natively,
//! and in WebAssembly built with the `threads` feature (shared memory, a pool of web
//! workers started from JavaScript). Without it, the same code runs in order.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(parallel)");
    let wasm = std::env::var("CARGO_CFG_TARGET_ARCH").is_ok_and(|arch| arch == "wasm32");
    if !wasm || std::env::var_os("CARGO_FEATURE_THREADS").is_some() {
        println!("cargo::rustc-cfg=parallel");
    }
}
