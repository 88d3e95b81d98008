//! `lab::photo::measure` on side photos of heaps standing on a plate of another grey, made here:
//! isosceles heaps at 25-40 deg drawn with anti-aliased edges on a background, on a plate wider
//! than the heap (some as wide as the photo, some with background or a table below), in several
//! greys (a plate between the others, darker than the heap, as dark as the heap, lighter than
//! the background), slightly blurred, with pixel noise. Without `--crop` every flank comes within
//! 1.5 deg and the plate's top edge within a row; a photo without a plate measures as before.

use image::{DynamicImage, GrayImage, Luma};
use lab::photo::{debug_picture, measure, PhotoSettings};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const W: u32 = 900;
const H: u32 = 600;
/// The plate's top row: the heap stands on it, its apex `HEAP_PX` higher.
const PLATE_TOP: f64 = 430.0;
const HEAP_PX: f64 = 170.0;

/// A made photo: the heap (flanks at `angle`), its plate and what lies around them.
struct Scene {
    angle: f64,
    background: f64,
    heap: f64,
    plate: f64,
    /// The plate's columns (None: the photo's width) and rows.
    plate_columns: Option<(f64, f64)>,
    plate_rows: f64,
    /// The grey below the plate (the background, or a table).
    below: f64,
    seed: u64,
}

impl Scene {
    /// What lies at (x, y), in pixels from the top left.
    fn grey_at(&self, x: f64, y: f64) -> f64 {
        let on_plate = self.plate_columns.is_none_or(|(a, b)| x >= a && x < b);
        if y >= PLATE_TOP && y < PLATE_TOP + self.plate_rows && on_plate {
            return self.plate;
        }
        if y >= PLATE_TOP {
            return if on_plate {
                self.below
            } else {
                self.background
            };
        }
        let centre = 0.5 * W as f64;
        let height = PLATE_TOP - y;
        if height <= HEAP_PX - (x - centre).abs() * self.angle.to_radians().tan() {
            self.heap
        } else {
            self.background
        }
    }

    /// The photo: each pixel the mean of 4 x 4 samples (anti-aliased edges), blurred
    /// (Gaussian, sigma 0.8 pixels), then normal noise of s.d. 10 grey levels.
    fn photo(&self) -> GrayImage {
        let sharp = GrayImage::from_fn(W, H, |x, y| {
            let mut sum = 0.0;
            for i in 0..4 {
                for j in 0..4 {
                    sum += self.grey_at(
                        x as f64 + (i as f64 + 0.5) / 4.0,
                        y as f64 + (j as f64 + 0.5) / 4.0,
                    );
                }
            }
            Luma([(sum / 16.0).round() as u8])
        });
        let mut img = imageproc::filter::gaussian_blur_f32(&sharp, 0.8);
        let mut rng = Pcg64::seed_from_u64(self.seed);
        for p in img.pixels_mut() {
            let (u1, u2): (f64, f64) = (rng.gen::<f64>().max(1e-12), rng.gen());
            let n = 10.0 * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
            p[0] = (p[0] as f64 + n).round().clamp(0.0, 255.0) as u8;
        }
        img
    }
}

fn scenes() -> Vec<(&'static str, Scene)> {
    let scene = |angle, background, heap, plate| Scene {
        angle,
        background,
        heap,
        plate,
        plate_columns: None,
        plate_rows: 140.0,
        below: background,
        seed: angle as u64,
    };
    vec![
        (
            "a grey plate across the photo between a light background and a dark heap",
            scene(25.0, 200.0, 60.0, 130.0),
        ),
        (
            "a plate darker than the heap, to the photo's foot, narrower than the photo",
            Scene {
                plate_columns: Some((30.0, 870.0)),
                plate_rows: 400.0,
                ..scene(30.0, 210.0, 110.0, 40.0)
            },
        ),
        (
            "a plate lighter than the background, a darker table below",
            Scene {
                plate_rows: 100.0,
                below: 70.0,
                ..scene(35.0, 110.0, 30.0, 235.0)
            },
        ),
        (
            "a light heap on a mid-grey plate on a dark background",
            Scene {
                plate_columns: Some((160.0, 740.0)),
                plate_rows: 60.0,
                ..scene(40.0, 40.0, 200.0, 120.0)
            },
        ),
        (
            "a dark heap on a plate of nearly its grey",
            scene(30.0, 215.0, 70.0, 85.0),
        ),
        (
            "a light heap on a plate lighter still",
            Scene {
                seed: 7,
                ..scene(35.0, 50.0, 150.0, 235.0)
            },
        ),
        (
            "a dark heap on a light plate, a light background",
            Scene {
                seed: 8,
                plate_columns: Some((50.0, 850.0)),
                ..scene(40.0, 170.0, 40.0, 240.0)
            },
        ),
    ]
}

#[test]
fn flanks_within_one_and_a_half_degrees_on_a_plate_without_crop() {
    for (what, scene) in scenes() {
        let img = DynamicImage::ImageLuma8(scene.photo());
        let a = measure(&img, &PhotoSettings::default()).unwrap_or_else(|e| panic!("{what}: {e}"));
        // What one threshold over the whole photo made of it.
        let whole = PhotoSettings {
            find_plate: false,
            ..PhotoSettings::default()
        };
        let before = match measure(&img, &whole) {
            Ok(b) => format!("{:.2} / {:.2} deg", b.left_deg, b.right_deg),
            Err(e) => format!("failed: {e}"),
        };
        eprintln!(
            "{what}: drawn {} deg, measured {:.2} / {:.2} deg (without the plate search: {before}); {}",
            scene.angle, a.left_deg, a.right_deg, a.base_line
        );
        for got in [a.left_deg, a.right_deg] {
            assert!(
                (got - scene.angle).abs() < 1.5,
                "{what}: drawn {}, measured {got:.2}",
                scene.angle
            );
        }
        let plate = a
            .plate
            .as_ref()
            .unwrap_or_else(|| panic!("{what}: no plate"));
        assert!(
            (plate.top_row as f64 - PLATE_TOP).abs() <= 1.0,
            "{what}: plate at row {}",
            plate.top_row
        );
        assert!(
            (plate.grey - scene.plate / 255.0).abs() < 0.03,
            "{what}: plate grey {}",
            plate.grey
        );
        assert!(
            a.base_line.starts_with(&format!(
                "base line found at row {} (a plate ",
                plate.top_row
            )) && a.base_line.ends_with("below the heap): measured above it"),
            "{}",
            a.base_line
        );
        // The heap stands on the plate: its last row just above the base line.
        assert!(a.base_row < plate.top_row && a.base_row + 3 >= plate.top_row);
    }
}

#[test]
fn the_plate_is_in_the_json_and_drawn_in_the_check() {
    let (_, scene) = scenes().remove(0);
    let img = DynamicImage::ImageLuma8(scene.photo());
    let s = PhotoSettings::default();
    let a = measure(&img, &s).unwrap();
    let json = serde_json::to_value(&a).unwrap();
    assert_eq!(json["plate"]["top_row"], a.plate.as_ref().unwrap().top_row);
    assert_eq!(json["base_line"], a.base_line.as_str());
    // Blue across the photo on the plate's top row, far from the heap.
    let check = debug_picture(&img, &s, &a);
    let row = a.plate.as_ref().unwrap().top_row;
    assert_eq!(check.get_pixel(5, row).0, [40, 90, 230]);
    assert_eq!(check.get_pixel(W - 5, row).0, [40, 90, 230]);
    // Cropped above the plate by hand, no plate is found and the angles agree within 0.3 deg.
    let cropped = PhotoSettings {
        crop: Some((0, 0, W, PLATE_TOP as u32)),
        ..PhotoSettings::default()
    };
    let c = measure(&img, &cropped).unwrap();
    assert!(c.plate.is_none(), "{}", c.base_line);
    assert!((c.left_deg - a.left_deg).abs() < 0.3 && (c.right_deg - a.right_deg).abs() < 0.3);
}

/// A heap on plain background (with a spread toe, a flat top, or touching the photo's side):
/// no plate is found, and the angles are those measured without looking for one.
#[test]
fn without_a_plate_nothing_changes() {
    let plain = |angle: f64, flat_top: f64, centre: f64, seed: u64| {
        let t = angle.to_radians().tan();
        let sharp = GrayImage::from_fn(W, H, |x, y| {
            let height = 460.0 - y as f64;
            let mut z = (HEAP_PX - (x as f64 - centre).abs() * t).min(HEAP_PX - flat_top);
            // A toe: a thin spread edge a few pixels high beyond the flanks' feet.
            z = z.max(6.0 * (-(-z).max(0.0) / 25.0).exp());
            Luma([if height >= 0.0 && height <= z {
                70
            } else {
                190
            }])
        });
        let mut img = sharp;
        let mut rng = Pcg64::seed_from_u64(seed);
        for p in img.pixels_mut() {
            p[0] = (p[0] as f64 + rng.gen_range(-25.0..25.0)).clamp(0.0, 255.0) as u8;
        }
        DynamicImage::ImageLuma8(img)
    };
    for (angle, flat_top, centre) in [
        (30.0, 0.0, 450.0),
        (25.0, 30.0, 450.0),
        (35.0, 0.0, 700.0),
        (40.0, 60.0, 300.0),
    ] {
        let img = plain(angle, flat_top, centre, angle as u64);
        let a = measure(&img, &PhotoSettings::default()).unwrap();
        let whole = PhotoSettings {
            find_plate: false,
            ..PhotoSettings::default()
        };
        let b = measure(&img, &whole).unwrap();
        eprintln!(
            "plain {angle} deg: {:.2} / {:.2}; {}",
            a.left_deg, a.right_deg, a.base_line
        );
        assert!(a.plate.is_none(), "{angle}: {}", a.base_line);
        assert_eq!(
            a.base_line,
            "no plate found below the heap: the whole photo measured"
        );
        assert_eq!((a.left_deg, a.right_deg), (b.left_deg, b.right_deg));
        assert!((a.left_deg - angle).abs() < 1.0 && (a.right_deg - angle).abs() < 1.0);
    }
    // The CLI test's picture (crates/cli/tests/lab_cli.rs): no noise, a flat top, the right
    // flank running out of the photo.
    let (tl, tr) = (32f64.to_radians().tan(), 28f64.to_radians().tan());
    let img = DynamicImage::ImageLuma8(GrayImage::from_fn(700, 420, |x, y| {
        let (x, height) = (x as f64, 380.0 - y as f64);
        let z = (200.0 - (330.0 - x).abs() * if x < 330.0 { tl } else { tr }).min(190.0);
        Luma([if height >= 0.0 && height <= z {
            60
        } else {
            220
        }])
    }));
    let a = measure(&img, &PhotoSettings::default()).unwrap();
    assert!(a.plate.is_none(), "{}", a.base_line);
    assert!((a.left_deg - 32.0).abs() < 1.0 && (a.right_deg - 28.0).abs() < 1.0);
}
