//! Tells the library's tests which instruction sets the building machine runs, so that the
//! tests of loops this CPU cannot run are reported as ignored rather than passed. The library
//! itself chooses its loops at run time (`rbf::Isa`) and does not read these flags.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(host_has_avx2)");
    println!("cargo::rustc-check-cfg=cfg(host_has_avx512)");
    println!("cargo::rerun-if-changed=build.rs");
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            println!("cargo::rustc-cfg=host_has_avx2");
            if std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx512dq")
                && std::is_x86_feature_detected!("avx512vl")
            {
                println!("cargo::rustc-cfg=host_has_avx512");
            }
        }
    }
}
