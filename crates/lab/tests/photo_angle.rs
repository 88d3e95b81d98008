//! `lab::photo::measure` on synthetic side photos of heaps drawn at known flank angles, with a
//! rounded apex, a spread toe, grey-level noise, light specks inside the heap and dark specks
//! outside it: each flank within 1 degree.

use image::{DynamicImage, GrayImage, Luma};
use lab::photo::{measure, Background, PhotoSettings, Threshold};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// A dark heap on a light background (or the reverse), 900 x 520 pixels, base on row 460, the
/// flanks rising at `left` and `right` degrees to a rounded apex about 260 pixels high.
fn heap_photo(left: f64, right: f64, seed: u64, light_heap: bool) -> GrayImage {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (w, h, base, apex_x, peak) = (900u32, 520u32, 460.0, 430.0, 290.0);
    let (tl, tr) = (left.to_radians().tan(), right.to_radians().tan());
    let (heap, ground) = if light_heap {
        (200.0, 60.0)
    } else {
        (70.0, 190.0)
    };
    GrayImage::from_fn(w, h, |x, y| {
        let x = x as f64;
        // The two flanks through the peak, joined by a soft minimum: a rounded apex.
        let zl = peak - (apex_x - x) * tl;
        let zr = peak - (x - apex_x) * tr;
        let k = 10.0;
        let mut z = -k * ((-zl / k).exp() + (-zr / k).exp()).ln();
        // The toe: a thin spread edge a few pixels high beyond the flanks' feet.
        z = z.max(6.0 * (-(-z).max(0.0) / 25.0).exp());
        let height = base - y as f64;
        let inside = height >= 0.0 && height <= z;
        let mut v = if inside { heap } else { ground };
        // Specks: light ones in the heap (gaps between kernels), dark ones on the background.
        if rng.gen::<f64>() < 0.01 {
            v = if inside { ground } else { heap };
        }
        // Grey-level noise, normal by Box-Muller, s.d. 20.
        let (u1, u2): (f64, f64) = (rng.gen::<f64>().max(1e-12), rng.gen());
        v += 20.0 * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
        Luma([v.clamp(0.0, 255.0) as u8])
    })
}

#[test]
fn flanks_within_one_degree_at_known_angles() {
    for (seed, (left, right, light, threshold)) in [
        (30.0, 35.0, false, Threshold::Otsu),
        (25.0, 25.0, false, Threshold::Iterative),
        (40.0, 33.0, true, Threshold::Otsu),
        (38.65, 27.35, false, Threshold::Iterative),
    ]
    .into_iter()
    .enumerate()
    {
        let img = DynamicImage::ImageLuma8(heap_photo(left, right, seed as u64 + 1, light));
        let s = PhotoSettings {
            threshold,
            ..PhotoSettings::default()
        };
        let a = measure(&img, &s).unwrap();
        eprintln!(
            "drawn {left} / {right} deg: measured {:.2} / {:.2} deg (threshold {:?} {})",
            a.left_deg, a.right_deg, threshold, a.threshold
        );
        assert!(
            (a.left_deg - left).abs() < 1.0 && (a.right_deg - right).abs() < 1.0,
            "drawn {left} / {right}, measured {:.2} / {:.2} (threshold {})",
            a.left_deg,
            a.right_deg,
            a.threshold
        );
        assert!((a.mean_deg - 0.5 * (a.left_deg + a.right_deg)).abs() < 1e-12);
    }
}

#[test]
fn the_background_side_and_crop_can_be_given() {
    let img = DynamicImage::ImageLuma8(heap_photo(30.0, 30.0, 9, false));
    // Told the truth, the same answer as found alone.
    let auto = measure(&img, &PhotoSettings::default()).unwrap();
    let told = PhotoSettings {
        background: Background::Light,
        ..PhotoSettings::default()
    };
    assert_eq!(measure(&img, &told).unwrap().left_deg, auto.left_deg);
    // A crop around the heap gives the same angles within a tenth of a degree.
    let cropped = PhotoSettings {
        crop: Some((20, 100, 860, 400)),
        ..PhotoSettings::default()
    };
    let c = measure(&img, &cropped).unwrap();
    assert!((c.left_deg - auto.left_deg).abs() < 0.1 && (c.right_deg - auto.right_deg).abs() < 0.1);
    // A crop outside the image, or one that cuts a flank away, is one line.
    let outside = PhotoSettings {
        crop: Some((800, 0, 200, 100)),
        ..PhotoSettings::default()
    };
    assert!(measure(&img, &outside)
        .unwrap_err()
        .contains("outside the 900 x 520"));
    // A flat image has no heap.
    let flat = DynamicImage::ImageLuma8(GrayImage::from_pixel(200, 200, Luma([128])));
    assert!(measure(&flat, &PhotoSettings::default()).is_err());
}
