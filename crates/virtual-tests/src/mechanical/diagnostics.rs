//! What a mechanical run records beside its curve, to see why a specimen fails or does not: the
//! largest overlaps (do spheres pass through each other or the tool instead of loading the
//! bonds?), every bond's stress against its strength at the peak force, and side views of the
//! specimen at stages of the loading with the broken bonds marked.

use std::collections::HashMap;

use dem::bond::Bonds;
use dem::Simulation;
use glam::DVec3;
use plotters::prelude::*;
use serde::Serialize;

/// The largest overlap seen over the run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LargestOverlap {
    /// Overlap over the smaller radius (a sphere against a geometry: over its radius). 1 means
    /// the centre of one sphere reached the surface of the other.
    pub relative: f64,
    /// Tool travel when it was seen (m, from the tool's start).
    pub at_travel_m: f64,
    /// The sphere pair's stable ids, or the sphere and the geometry.
    pub between: String,
}

/// Overlaps, tracked over a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Overlaps {
    /// Between two spheres.
    pub spheres: LargestOverlap,
    /// Between a sphere and a geometry (the tool, a support).
    pub geometry: LargestOverlap,
}

impl Overlaps {
    /// Looks at the simulation now (tool travel `travel`).
    pub fn observe(&mut self, sim: &mut Simulation, travel: f64) {
        if let Some((rel, a, b)) = sim.largest_relative_overlap() {
            if rel > self.spheres.relative {
                self.spheres = LargestOverlap {
                    relative: rel,
                    at_travel_m: travel,
                    between: format!("spheres {a} and {b}"),
                };
            }
        }
        if let Some((rel, a, g)) = sim.largest_wall_overlap() {
            if rel > self.geometry.relative {
                self.geometry = LargestOverlap {
                    relative: rel,
                    at_travel_m: travel,
                    between: format!("sphere {a} and {g}"),
                };
            }
        }
    }
}

/// The bonds' stresses against their strengths at the peak force.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BondStress {
    /// Intact bonds at the peak.
    pub intact: usize,
    /// Largest sigma / sigma_c and tau / tau_c over the intact bonds (1 breaks).
    pub max_tension_ratio: f64,
    pub max_shear_ratio: f64,
    /// 99th and 50th percentiles of each.
    pub p99_tension_ratio: f64,
    pub p99_shear_ratio: f64,
    pub median_tension_ratio: f64,
    pub median_shear_ratio: f64,
    /// Counts of bonds by the larger of the two ratios, in tenths: [0, 0.1), [0.1, 0.2), ...,
    /// [0.9, 1).
    pub histogram: Vec<usize>,
}

impl BondStress {
    /// The bonds' state now.
    pub fn of(bonds: &Bonds) -> BondStress {
        let ratios = bonds.stress_ratios();
        let mut tension: Vec<f64> = ratios.iter().map(|r| r.0).collect();
        let mut shear: Vec<f64> = ratios.iter().map(|r| r.1).collect();
        let mut histogram = vec![0usize; 10];
        for r in &ratios {
            let k = ((r.0.max(r.1) * 10.0).floor().max(0.0) as usize).min(9);
            histogram[k] += 1;
        }
        let q = |v: &mut Vec<f64>, f: f64| -> f64 {
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(f64::total_cmp);
            v[((v.len() - 1) as f64 * f).round() as usize]
        };
        BondStress {
            intact: ratios.len(),
            max_tension_ratio: q(&mut tension, 1.0),
            max_shear_ratio: q(&mut shear, 1.0),
            p99_tension_ratio: q(&mut tension, 0.99),
            p99_shear_ratio: q(&mut shear, 0.99),
            median_tension_ratio: q(&mut tension, 0.5),
            median_shear_ratio: q(&mut shear, 0.5),
            histogram,
        }
    }
}

/// The specimen at one stage: sphere centres and radii by stable id, where the bonds broken so
/// far broke, and the boxes of the fixture.
#[derive(Clone, Debug)]
pub struct Stage {
    pub label: String,
    pub travel: f64,
    pub force: f64,
    spheres: Vec<(u32, DVec3, f64)>,
    /// Where each bond broken so far broke (its mid-point then).
    broken: Vec<DVec3>,
    boxes: Vec<(DVec3, DVec3)>,
}

impl Stage {
    /// Takes the specimen as it is now.
    pub fn take(sim: &Simulation, label: String, travel: f64, force: f64) -> Stage {
        let p = &sim.particles;
        let spheres: Vec<(u32, DVec3, f64)> = (0..p.len())
            .map(|k| (p.id[k], p.position[k], p.radius[k]))
            .collect();
        let broken = sim
            .bonds()
            .map(|b| b.breakages().iter().map(|x| x.position).collect())
            .unwrap_or_default();
        let boxes = sim
            .geometries
            .iter()
            .filter_map(|g| {
                let (lo, hi) = g.elements.iter().map(|e| e.bounds()).fold(
                    (DVec3::INFINITY, DVec3::NEG_INFINITY),
                    |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
                );
                (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
            })
            .collect();
        Stage {
            label,
            travel,
            force,
            spheres,
            broken,
            boxes,
        }
    }
}

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("side view: {e:?}")
}

/// Blue (not moved) to red (moved `scale` or more).
fn colour(moved: f64, scale: f64) -> RGBColor {
    let t = (moved / scale).clamp(0.0, 1.0);
    RGBColor(
        (40.0 + 215.0 * t) as u8,
        (90.0 + 60.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
        (220.0 - 190.0 * t) as u8,
    )
}

/// The 99th percentile of `values` (0 for none).
fn p99(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(((v.len() as f64 - 1.0) * 0.99) as usize)
        .copied()
        .unwrap_or(0.0)
}

/// A side view (x across, z up) of the middle slab of the specimen (|y| below the largest
/// radius) at `stage`: each sphere coloured by how far it has moved since `start` (the scale ends
/// at the 99th percentile, so a few pieces flung away do not wash it out), a red dot where each
/// bond broken so far broke (anywhere along y), the fixture's blocks outlined in grey.
pub fn side_view_svg(start: &Stage, stage: &Stage) -> Result<String, String> {
    let origin: HashMap<u32, DVec3> = start.spheres.iter().map(|s| (s.0, s.1)).collect();
    let rmax = start.spheres.iter().map(|s| s.2).fold(0.0, f64::max);
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for s in &start.spheres {
        lo = lo.min(s.1 - DVec3::splat(s.2));
        hi = hi.max(s.1 + DVec3::splat(s.2));
    }
    // Room below for what the tool pushes down: as far as it has travelled.
    lo.z -= stage.travel;
    let pad = 0.1 * (hi.z - lo.z);
    let (x0, x1) = (lo.x - pad, hi.x + pad);
    let (z0, z1) = (lo.z - pad, hi.z + pad);
    let moved: Vec<f64> = stage
        .spheres
        .iter()
        .map(|s| origin.get(&s.0).map_or(0.0, |o| (s.1 - *o).length()))
        .collect();
    let scale = p99(&moved).max(1e-9);
    let width = 900u32;
    let height = ((width as f64) * (z1 - z0) / (x1 - x0)).clamp(200.0, 900.0) as u32 + 60;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "{}: travel {:.2} mm, force {:.1} N, {} bonds broken (red); colour: moved 0 to {:.2} mm or more",
                    stage.label,
                    1e3 * stage.travel,
                    stage.force,
                    stage.broken.len(),
                    1e3 * scale
                ),
                ("sans-serif", 15),
            )
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(40)
            .build_cartesian_2d(1e3 * x0..1e3 * x1, 1e3 * z0..1e3 * z1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (mm)")
            .y_desc("z (mm)")
            .draw()
            .map_err(err)?;
        let inside = |x: &DVec3| x.x > x0 && x.x < x1 && x.z > z0 && x.z < z1;
        // Pixels per millimetre, for the circles' size.
        let px = (width as f64 - 60.0) / (1e3 * (x1 - x0));
        let slab = stage
            .spheres
            .iter()
            .zip(&moved)
            .filter(|(s, _)| s.1.y.abs() < rmax && inside(&s.1));
        chart
            .draw_series(slab.map(|(s, m)| {
                Circle::new(
                    (1e3 * s.1.x, 1e3 * s.1.z),
                    (1e3 * s.2 * px).max(1.0),
                    colour(*m, scale).filled(),
                )
            }))
            .map_err(err)?;
        chart
            .draw_series(
                stage
                    .broken
                    .iter()
                    .filter(|x| inside(x))
                    .map(|x| Circle::new((1e3 * x.x, 1e3 * x.z), 2, RED.filled())),
            )
            .map_err(err)?;
        let grey = RGBColor(90, 90, 90);
        let boxes = stage
            .boxes
            .iter()
            .map(|(a, b)| {
                (
                    a.max(DVec3::new(x0, 0.0, z0)),
                    b.min(DVec3::new(x1, 0.0, z1)),
                )
            })
            .filter(|(a, b)| a.x < b.x && a.z < b.z);
        chart
            .draw_series(boxes.map(|(a, b)| {
                Rectangle::new(
                    [(1e3 * a.x, 1e3 * a.z), (1e3 * b.x, 1e3 * b.z)],
                    grey.stroke_width(2),
                )
            }))
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn the_colour_runs_from_blue_to_red() {
        assert_eq!(colour(0.0, 1.0), RGBColor(40, 90, 220));
        assert_eq!(colour(2.0, 1.0), RGBColor(255, 90, 30));
    }
}
