//! Puts the board's memory layout, as `memory.x`, where cortex-m-rt's
//! link.x finds it. (The crate root has no memory.x of its own: the linker
//! would find that one first.)
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    let memory = if env::var_os("CARGO_FEATURE_STM32F4").is_some() { "memory-stm32f4.x" } else { "memory-mps2.x" };
    let text = fs::read(memory).unwrap_or_default();
    if fs::write(out.join("memory.x"), text).is_ok() {
        println!("cargo:rustc-link-search={}", out.display());
    }
    println!("cargo:rerun-if-changed=memory-mps2.x");
    println!("cargo:rerun-if-changed=memory-stm32f4.x");
    println!("cargo:rerun-if-changed=build.rs");
}
