//! The largest render the options may ask for, measured where each bound bites; the options and
//! their errors both name them.

/// Longest image side in pixels.
pub const MAX_SIDE: u32 = 65_536;

/// Most pixels in one image: 2²⁷ (e.g. 16384 × 8192). Measured peak memory of an RGB render
/// is 106 bytes per pixel (112 MB at 1000², 33 MB at 500²; `/usr/bin/time -v spectrace render
/// --width 1000 --height 1000 --spectral rgb`), 80 of them the film's fixed-point sums, so
/// about 14 GB at the limit; `--width 65536 --height 65536` (2³² pixels) aborted allocating.
pub const MAX_PIXELS: u64 = 1 << 27;

/// Most pixel × wavelength samples of a spectral film: 2²⁸. Measured 20.6 bytes per sample at
/// peak (1.97 GB for 1000² × 95 wavelengths, 0.50 GB for 500² × 95: a 16-byte sum and the f32
/// image value), so about 5.5 GB at the limit; e.g. 1680² pixels at 95 wavelengths.
pub const MAX_SPECTRAL_SAMPLES: u64 = 1 << 28;

/// Most worker threads: each reserves a stack; `--threads 100000` hung creating the pool.
pub const MAX_THREADS: usize = 1024;
