//! The ꟻLIP this crate reports is NVIDIA's: on known pairs of images (a gradient with
//! shapes against noisy, shifted, blurred and recoloured versions of itself), the error
//! maps of `perceptual::flip` agree with NVIDIA's reference Python package `flip-evaluator`
//! (`pip install flip-evaluator`, which `.ci/run` installs). Without the package the test
//! says SKIPPED; in CI it fails.

mod common;
use common::*;
use std::process::Command;
use warpfit::perceptual::flip;

const W: u32 = 96;
const H: u32 = 64;

/// An 8-bit sRGB test card: gradients, a disc, stripes.
fn card(variant: u32) -> Vec<u8> {
    let mut px = Vec::with_capacity((W * H * 3) as usize);
    for y in 0..H {
        for x in 0..W {
            let (fx, fy) = (x as f32 / W as f32, y as f32 / H as f32);
            let shift = if variant == 2 { 0.03 } else { 0.0 };
            let disc = ((fx - 0.6 - shift).powi(2) + (fy - 0.5).powi(2)).sqrt() < 0.2;
            let stripes = ((fx * 24.0) as u32).is_multiple_of(2) && fy > 0.8;
            let mut c = [fx, fy * 0.8, 0.3 + 0.4 * (fx * fy)];
            if disc {
                c = [0.9, 0.2, 0.1];
            }
            if stripes {
                c = [1.0, 1.0, 1.0];
            }
            match variant {
                1 => {
                    let n = ((x * 7919 + y * 104729) % 97) as f32 / 97.0 - 0.5;
                    c = c.map(|v| v + 0.08 * n);
                }
                3 => c = [c[1], c[0], c[2]],
                4 => c = c.map(|v| v * 0.7),
                _ => {}
            }
            px.extend(c.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8));
        }
    }
    px
}

const CHECK: &str = r#"
import sys, flip_evaluator as flip
ref = flip.load(sys.argv[1])
for path in sys.argv[2:]:
    _, mean, _ = flip.evaluate(ref, flip.load(path), "LDR", applyMagma=False)
    print(mean)
"#;

#[test]
fn flip_matches_nvidias_reference_implementation() {
    let has = Command::new("python3")
        .args(["-c", "import flip_evaluator"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !has {
        tool_missing(
            "ꟻLIP against NVIDIA's reference",
            "the flip-evaluator Python package",
            "pip install flip-evaluator",
        );
        return;
    }
    let dir = tmp_dir("flip-reference");
    let reference = card(0);
    let path = |k: u32| dir.join(format!("card{k}.png"));
    for k in 0..5 {
        warpfit::preview::write_png(&path(k), W, H, &card(k)).unwrap();
    }
    let out = Command::new("python3").args(["-c", CHECK]).arg(path(0)).args((0..5).map(path)).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let theirs: Vec<f64> = String::from_utf8_lossy(&out.stdout).lines().map(|l| l.trim().parse().unwrap()).collect();
    assert_eq!(theirs.len(), 5);
    for k in 0..5 {
        let ours = flip::mean(&flip::flip_ldr(&reference, &card(k), W, H));
        let t = theirs[k as usize];
        println!("pair {k}: ours {ours:.6}, NVIDIA's {t:.6}");
        assert!((ours - t).abs() <= 1e-3 * t.max(1e-3), "pair {k}: ours {ours}, NVIDIA's {t}");
        if k == 0 {
            assert_eq!(ours, 0.0, "identical images");
        } else {
            assert!(ours > 0.005, "pair {k} differs visibly: {ours}");
        }
    }
}
