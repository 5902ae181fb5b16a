//! Arbitrary bytes as a `.npy` file: the header, dtype and shape checks, then (2-D frames of a
//! known exp-map width) forward kinematics as a seed would get.
#![no_main]
use libfuzzer_sys::fuzz_target;
use motion_core::formats::npy::parse_npy_dyn;
use motion_core::Motion;

fuzz_target!(|data: &[u8]| {
    let Ok(array) = parse_npy_dyn(data, std::path::Path::new("fuzz.npy")) else {
        return;
    };
    if let Ok(frames) = array.into_dimensionality::<ndarray::Ix2>() {
        if frames.nrows() <= 64 {
            if let Some(Ok(motion)) = Motion::expmap_of_width(frames, 25.0) {
                let _ = motion.positions();
            }
        }
    }
});
