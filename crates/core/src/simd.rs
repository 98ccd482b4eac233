//! The one way the crate's numeric kernels use AVX2 and FMA: each kernel is written once, as a
//! plain `#[inline(always)]` function, and [`with_avx2!`] defines its entry point, which runs a
//! copy compiled for AVX2 and FMA when the CPU has them (checked at run time: the build targets
//! baseline x86-64) and the plain one otherwise. No intrinsics: the compiler vectorises the
//! kernels' 4-wide loops for the wider instruction set.

/// Whether this CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn has_avx2_fma() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

/// Defines `fn $name<T: Bound>(args) -> R` that runs `$generic` compiled for AVX2 and FMA when
/// the CPU has them, and as it is otherwise (the type parameter and the return type may be left
/// out). `$generic` should be `#[inline(always)]` so that the AVX2 copy gets its own code.
macro_rules! with_avx2 {
    ($(#[$meta:meta])* $vis:vis fn $name:ident $(<$t:ident: $bound:path>)? / $avx2:ident
        => $generic:ident ($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)?) => {
        $(#[$meta])*
        $vis fn $name $(<$t: $bound>)? ($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            if $crate::simd::has_avx2_fma() {
                // SAFETY: the CPU supports the features `$avx2` is compiled for (checked above).
                return unsafe { $avx2($($arg),*) };
            }
            $generic($($arg),*)
        }

        $(#[$meta])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma")]
        fn $avx2 $(<$t: $bound>)? ($($arg: $ty),*) $(-> $ret)? {
            $generic($($arg),*)
        }
    };
}
pub(crate) use with_avx2;
