//! The goniodiagram light of section 5: a point light whose intensity per direction comes
//! from a 2D non-uniform table over (plane, angle). Per packet: the spherical coordinates
//! of the direction in the luminaire's frame (approximate `acos`/`asin`/`atan2`), each
//! lane's cell by the N-wide binary search and bilinear interpolation inside it, both
//! shared with the tabulated BDFs ([`crate::tabulated`]).
//!
//! Beside the paper's search, [`GonioLookup::Uniform`] resamples the table once onto a
//! uniform grid, where a lane's cell is `floor(x / step)` (pbrt-v4's approach); `table2`
//! reports the time of both and the uniform grid's error at the file's own nodes.
//!
//! Frame: the luminaire's local `z` is its up axis (type C's nadir, gamma 0, is `-z`), `x`
//! is the C = 0 plane's direction, C grows towards `+y`. Types A and B (our reading of
//! LM-63; the aim axis is `-z` too): the polar axis is local `y` for B and `x` for A; the
//! plane angle is the rotation about the polar axis from the aim axis, the angle within
//! the plane the latitude towards the polar axis (`asin` of the direction's polar
//! component). Directions the file does not cover (gamma beyond its last angle,
//! floodlight planes beyond its range) get zero.

use coherent_simd::{Lanes, SimdF32, SimdMask, Vec3s};
use std::sync::Arc;

use glam::Vec3;

use super::photometry::{PhotometricTable, PhotometricType, WATTS_PER_LUMEN};
use super::{LightError, LightSample, check_colour, check_dir, check_point, finish_scaled, toward};
use crate::approx::{acos, atan2};
use crate::tabulated::{Axis, Cell, Grid};

/// The table of an IES (`.ies`) or EULUMDAT (`.ldt`) file's bytes, by `path`'s extension
/// (any case); errors name `path`. Neither format's text fields are used, so any 8-bit
/// encoding is read.
pub fn parse_table(path: &std::path::Path, bytes: &[u8]) -> Result<PhotometricTable, LightError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let text = String::from_utf8_lossy(bytes);
    match ext.as_deref() {
        Some("ies") => super::ies::parse(&text, path),
        Some("ldt") => super::ldt::parse(&text, path),
        _ => Err(LightError::File {
            path: path.to_path_buf(),
            problem: "not a goniodiagram file: expected the extension .ies (IES LM-63) or .ldt (EULUMDAT)".to_owned(),
        }),
    }
}

/// How a lane's table cell is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GonioLookup {
    /// The paper's non-uniform table and N-wide binary search.
    #[default]
    Search,
    /// The table resampled once onto a uniform grid (O(1) cell lookup).
    Uniform,
}

/// Default step of the uniform grid, in degrees.
pub const UNIFORM_STEP_DEG: f32 = 0.5;

/// A table resampled onto a uniform grid.
#[derive(Debug, Clone, PartialEq)]
pub struct UniformTable {
    /// First node and `1 / step` per axis (radians).
    start: [f32; 2],
    inv_step: [f32; 2],
    /// Nodes per axis.
    len: [usize; 2],
    /// Values, plane-major, padded by one so that `gather2` stays in range.
    values: Vec<f32>,
}

/// A point light whose intensity follows a goniodiagram.
#[derive(Debug, Clone, PartialEq)]
pub struct Goniodiagram {
    position: Vec3,
    /// The luminaire's x, y, z axes in world space.
    axes: [Vec3; 3],
    kind: PhotometricType,
    /// Candela over (plane, angle) in radians.
    grid: Arc<Grid<2>>,
    uniform: Arc<UniformTable>,
    lookup: GonioLookup,
    /// W/sr per candela, per channel.
    scale: [f32; 3],
}

impl Goniodiagram {
    /// A goniodiagram light at `position` with the luminaire's `up` axis and `x` axis (the
    /// C = 0 plane; made orthogonal to `up`), from a table as read from a file (any
    /// symmetry; see [`PhotometricTable::full`]). `colour` scales the radiometric
    /// intensity (`candela * WATTS_PER_LUMEN * colour`). Errors name `source` (the file).
    pub fn new(
        position: Vec3,
        up: Vec3,
        x: Vec3,
        table: &PhotometricTable,
        colour: [f32; 3],
        lookup: GonioLookup,
        source: &std::path::Path,
    ) -> Result<Self, LightError> {
        let position = check_point("goniodiagram", "position", position)?;
        let ez = check_dir("goniodiagram", "up", up)?;
        let ex = check_dir("goniodiagram", "x axis", x - ez * x.dot(ez)).map_err(|_| {
            LightError::bad(
                "goniodiagram",
                "x axis",
                x,
                "parallel to the up axis or zero",
            )
        })?;
        let ey = ez.cross(ex);
        let colour = check_colour("goniodiagram", "colour", colour)?;
        table.validate(source)?;
        let full = table.full(source)?;
        let (planes, angles, values) = pad_angles(&full);
        let to_err = |e: crate::tabulated::TableError| LightError::File {
            path: source.to_path_buf(),
            problem: format!("goniodiagram table: {e}"),
        };
        let rad = |v: &[f32]| v.iter().map(|x| x.to_radians()).collect::<Vec<_>>();
        let grid = Grid::new(
            [
                Axis::new(0, rad(&planes)).map_err(to_err)?,
                Axis::new(1, rad(&angles)).map_err(to_err)?,
            ],
            1,
            values,
        )
        .map_err(to_err)?;
        let uniform = resample(&grid, UNIFORM_STEP_DEG.to_radians());
        Ok(Goniodiagram {
            position,
            axes: [ex, ey, ez],
            kind: full.kind,
            grid: Arc::new(grid),
            uniform: Arc::new(uniform),
            lookup,
            scale: colour.map(|c| c * WATTS_PER_LUMEN),
        })
    }

    /// A goniodiagram light from an IES (`.ies`) or EULUMDAT (`.ldt`) file (by extension,
    /// any case); see [`Goniodiagram::new`] for the other arguments.
    pub fn load(
        path: &std::path::Path,
        position: Vec3,
        up: Vec3,
        x: Vec3,
        colour: [f32; 3],
        lookup: GonioLookup,
    ) -> Result<Self, LightError> {
        let bytes = std::fs::read(path).map_err(|source| LightError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let table = parse_table(path, &bytes)?;
        Goniodiagram::new(position, up, x, &table, colour, lookup, path)
    }

    /// The same light with another cell lookup.
    pub fn with_lookup(mut self, lookup: GonioLookup) -> Self {
        self.lookup = lookup;
        self
    }

    /// The table (candela over plane and angle, radians).
    pub fn grid(&self) -> &Grid<2> {
        &self.grid
    }

    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The luminaire's x, y, z (up) axes in world space.
    pub fn axes(&self) -> [Vec3; 3] {
        self.axes
    }

    /// The photometric type (which angles the table is over).
    pub fn kind(&self) -> PhotometricType {
        self.kind
    }

    /// W/sr per candela, per channel.
    pub fn scale(&self) -> [f32; 3] {
        self.scale
    }

    /// How a lane's table cell is found.
    pub fn lookup(&self) -> GonioLookup {
        self.lookup
    }

    /// The table resampled onto a uniform grid ([`GonioLookup::Uniform`] reads it).
    pub fn uniform_table(&self) -> &UniformTable {
        &self.uniform
    }

    /// Candela towards world directions `d` (unit, away from the light), per lane.
    #[inline(always)]
    pub fn candela<L: Lanes>(&self, l: L, d: &Vec3s<L>) -> L::F32s {
        let lx = Vec3s::splat(l, self.axes[0]).dot(*d);
        let ly = Vec3s::splat(l, self.axes[1]).dot(*d);
        let lz = Vec3s::splat(l, self.axes[2]).dot(*d);
        let coords = self.coords(l, lx, ly, lz);
        self.lookup_at(l, coords)
    }

    /// (plane, angle) in radians of local directions.
    #[inline(always)]
    fn coords<L: Lanes>(&self, l: L, x: L::F32s, y: L::F32s, z: L::F32s) -> [L::F32s; 2] {
        let zero = l.splat(0.0);
        match self.kind {
            PhotometricType::C => {
                let gamma = acos(l, -z);
                let c = atan2(l, y, x);
                let c = c.lt(zero).select(c + std::f32::consts::TAU, c);
                [c, gamma]
            }
            PhotometricType::B => [atan2(l, x, -z), asin(l, y)],
            PhotometricType::A => [atan2(l, y, -z), asin(l, x)],
        }
    }

    #[inline(always)]
    fn lookup_at<L: Lanes>(&self, l: L, x: [L::F32s; 2]) -> L::F32s {
        match self.lookup {
            GonioLookup::Search => {
                let cells = self.grid.locate(l, x);
                let mut out = [l.splat(0.0)];
                self.grid.interpolate(l, &cells, &mut out);
                out[0]
            }
            GonioLookup::Uniform => self.uniform.eval(l, x),
        }
    }

    #[inline(always)]
    pub fn sample<L: Lanes>(
        &self,
        l: L,
        p: &Vec3s<L>,
        n: &Vec3s<L>,
        active: L::Mask,
    ) -> LightSample<L> {
        let t = toward(l, p, n, active, &Vec3s::splat(l, self.position));
        let cd = self.candela(l, &-t.wi);
        let active = t.active & cd.gt(l.splat(0.0));
        finish_scaled(l, n, active, t.wi, t.dist, self.scale, cd * t.inv_d2)
    }

    /// The uniform grid's largest absolute error at the table's own nodes, and the largest
    /// candela (for a relative figure).
    pub fn uniform_error_at_nodes(&self) -> (f32, f32) {
        let a = self.grid.axes();
        let mut worst = 0.0f32;
        let mut max = 0.0f32;
        for (i, &pl) in a[0].nodes().iter().enumerate() {
            for (j, &an) in a[1].nodes().iter().enumerate() {
                let want = self.grid.node([i, j])[0];
                let got = self.uniform.eval1([pl, an]);
                worst = worst.max((got - want).abs());
                max = max.max(want);
            }
        }
        (worst, max)
    }
}

/// `asin` clamped to `[-1, 1]` first.
#[inline(always)]
fn asin<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    coherent_simd::approx::asin(l, x.clamp(l.splat(-1.0), l.splat(1.0)))
}

/// Zero angles beyond the file's range (type C: below its first and above its last gamma,
/// up to 0 and 180 degrees), so that directions it does not cover get nothing.
fn pad_angles(t: &PhotometricTable) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let (lo_end, hi_end) = match t.kind {
        PhotometricType::C => (0.0, 180.0),
        _ => (-90.0, 90.0),
    };
    let mut angles = t.angles.clone();
    let (mut pad_lo, mut pad_hi) = (0, 0);
    let first = angles[0];
    if first > lo_end {
        let eps = (first - lo_end).min(1e-2);
        if first - eps > lo_end {
            angles.insert(0, first - eps);
            pad_lo += 1;
        }
        angles.insert(0, lo_end);
        pad_lo += 1;
    }
    let last = *angles.last().unwrap();
    if last < hi_end {
        let eps = (hi_end - last).min(1e-2);
        if last + eps < hi_end {
            angles.push(last + eps);
            pad_hi += 1;
        }
        angles.push(hi_end);
        pad_hi += 1;
    }
    if angles.len() == 1 {
        angles.push(angles[0] + 1.0);
        pad_hi += 1;
    }
    let n = t.angles.len();
    let mut values = Vec::with_capacity(t.planes.len() * angles.len());
    for p in 0..t.planes.len() {
        values.extend(std::iter::repeat_n(0.0, pad_lo));
        if n == 1 {
            values.push(t.candela[p]);
            // One angle: constant over the padding that closes the axis.
            values.extend(std::iter::repeat_n(t.candela[p], pad_hi.min(1)));
            values.extend(std::iter::repeat_n(0.0, pad_hi.saturating_sub(1)));
        } else {
            values.extend_from_slice(&t.candela[p * n..(p + 1) * n]);
            values.extend(std::iter::repeat_n(0.0, pad_hi));
        }
    }
    let mut planes = t.planes.clone();
    if planes.len() == 1 {
        planes.push(planes[0] + 1.0);
        let row = values.clone();
        values.extend(row);
    }
    (planes, angles, values)
}

/// `grid` resampled at `step` radians (at least 2 nodes per axis) by its own bilinear
/// interpolation.
fn resample(grid: &Grid<2>, step: f32) -> UniformTable {
    let a = grid.axes();
    let mut start = [0.0; 2];
    let mut inv_step = [0.0; 2];
    let mut len = [0usize; 2];
    for k in 0..2 {
        let span = a[k].last() - a[k].first();
        let n = ((span / step).ceil() as usize).max(1) + 1;
        start[k] = a[k].first();
        inv_step[k] = (n - 1) as f32 / span;
        len[k] = n;
    }
    let mut values = Vec::with_capacity(len[0] * len[1] + 1);
    for i in 0..len[0] {
        let x = (start[0] + i as f32 / inv_step[0]).min(a[0].last());
        for j in 0..len[1] {
            let y = (start[1] + j as f32 / inv_step[1]).min(a[1].last());
            values.push(grid.interpolate1([x, y])[0]);
        }
    }
    values.push(0.0);
    UniformTable {
        start,
        inv_step,
        len,
        values,
    }
}

impl UniformTable {
    /// Each axis's cell and weight.
    #[inline(always)]
    fn cell<L: Lanes>(&self, l: L, k: usize, x: L::F32s) -> Cell<L> {
        let f = ((x - self.start[k]) * self.inv_step[k])
            .clamp(l.splat(0.0), l.splat((self.len[k] - 1) as f32));
        let i = f.floor().min(l.splat((self.len[k] - 2) as f32));
        Cell {
            index: i.to_i32(),
            t: f - i,
        }
    }

    /// Bilinear interpolation per lane.
    #[inline(always)]
    pub fn eval<L: Lanes>(&self, l: L, x: [L::F32s; 2]) -> L::F32s {
        let (c0, c1) = (self.cell(l, 0, x[0]), self.cell(l, 1, x[1]));
        let base = c0.index * l.splat_i32(self.len[1] as i32) + c1.index;
        let (a, b) = l.gather2(&self.values, base);
        let (c, d) = l.gather2(&self.values, base + l.splat_i32(self.len[1] as i32));
        let one = l.splat(1.0);
        let lo = a.mul_add(one - c1.t, b * c1.t);
        let hi = c.mul_add(one - c1.t, d * c1.t);
        lo.mul_add(one - c0.t, hi * c0.t)
    }

    /// [`UniformTable::eval`] for one point (scalar backend).
    pub fn eval1(&self, x: [f32; 2]) -> f32 {
        self.eval(coherent_simd::scalar::Scalar, x)
    }

    /// The nodes along axis `k` (0: plane, 1: angle; radians).
    pub fn nodes(&self, k: usize) -> Vec<f32> {
        (0..self.len[k])
            .map(|i| self.start[k] + i as f32 / self.inv_step[k])
            .collect()
    }

    /// The values at the nodes, plane-major (`len(0) * len(1)` of them).
    pub fn node_values(&self) -> &[f32] {
        &self.values[..self.len[0] * self.len[1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::Light;
    use crate::light::test_util::irradiance1;
    use coherent_simd::scalar::Scalar;
    use std::path::Path;

    /// A known intensity function of (C, gamma) in degrees.
    fn known(c: f32, g: f32) -> f32 {
        let (c, g) = (c.to_radians(), g.to_radians());
        100.0 + 80.0 * g.cos() + 30.0 * (2.0 * c).cos() * g.sin()
    }

    fn table() -> PhotometricTable {
        // Non-uniform nodes, full circle of planes.
        let planes = vec![0.0, 20.0, 45.0, 90.0, 100.0, 180.0, 270.0, 300.0, 360.0];
        let angles = vec![0.0, 5.0, 10.0, 30.0, 60.0, 90.0, 120.0, 180.0];
        let mut candela = Vec::new();
        for &c in &planes {
            for &g in &angles {
                candela.push(known(c, g));
            }
        }
        PhotometricTable {
            kind: PhotometricType::C,
            planes,
            angles,
            candela,
        }
    }

    fn light(lookup: GonioLookup) -> Goniodiagram {
        Goniodiagram::new(
            Vec3::ZERO,
            Vec3::Z,
            Vec3::X,
            &table(),
            [1.0; 3],
            lookup,
            Path::new("known"),
        )
        .unwrap()
    }

    /// The world direction of (C, gamma) degrees in the light's frame (up z, C=0 along x).
    fn dir(c: f32, g: f32) -> Vec3 {
        let (c, g) = (c.to_radians(), g.to_radians());
        Vec3::new(g.sin() * c.cos(), g.sin() * c.sin(), -g.cos())
    }

    #[test]
    fn a_table_of_a_known_function_reproduces_it_at_its_nodes_and_interpolates_between() {
        let t = table();
        for lookup in [GonioLookup::Search, GonioLookup::Uniform] {
            let g = light(lookup);
            for (i, &c) in t.planes.iter().enumerate() {
                for (j, &a) in t.angles.iter().enumerate() {
                    if a == 0.0 || a == 180.0 {
                        continue; // the poles: C is undefined there
                    }
                    let d = dir(c, a);
                    let got = g.candela(Scalar, &Vec3s::splat(Scalar, d));
                    // The approximate acos/atan2 (7e-5 rad) times the steepest slope.
                    assert!(
                        (got - t.at(i, j)).abs() < 0.05,
                        "{lookup:?} node ({c}, {a}): {got} vs {}",
                        t.at(i, j)
                    );
                }
            }
            // Between nodes: bilinear in the cell, within the cell's spread of values.
            let d = dir(30.0, 20.0);
            let got = g.candela(Scalar, &Vec3s::splat(Scalar, d));
            let want = g
                .grid
                .interpolate1([30f32.to_radians(), 20f32.to_radians()])[0];
            assert!((got - want).abs() < 0.05, "{lookup:?}: {got} vs {want}");
            assert!(
                (got - known(30.0, 20.0)).abs() < 2.0,
                "{got} vs {}",
                known(30.0, 20.0)
            );
        }
        let (err, max) = light(GonioLookup::Uniform).uniform_error_at_nodes();
        assert!(err <= 1e-3 * max, "uniform grid error {err} of {max}");
    }

    #[test]
    fn irradiance_is_the_tabulated_intensity_over_d2() {
        let g = Light::Goniodiagram(
            Goniodiagram::new(
                Vec3::new(0.0, 0.0, 2.0),
                Vec3::Z,
                Vec3::X,
                &table(),
                [683.0; 3],
                GonioLookup::Search,
                Path::new("known"),
            )
            .unwrap(),
        );
        // Straight below: gamma 0, I = 180 cd -> 180 W/sr at colour 683.
        let e = irradiance1(&g, Vec3::ZERO, Vec3::Z);
        assert!((e[0] - 180.0 / 4.0).abs() < 0.05, "{e:?}");
    }

    #[test]
    fn directions_the_file_does_not_cover_get_nothing() {
        // A downlight table (gamma 0..90): nothing above the horizon.
        let t = PhotometricTable {
            kind: PhotometricType::C,
            planes: vec![0.0],
            angles: vec![0.0, 45.0, 90.0],
            candela: vec![10.0, 8.0, 5.0],
        };
        let g = Goniodiagram::new(
            Vec3::ZERO,
            Vec3::Z,
            Vec3::X,
            &t,
            [1.0; 3],
            GonioLookup::Search,
            Path::new("down"),
        )
        .unwrap();
        assert_eq!(
            g.candela(Scalar, &Vec3s::splat(Scalar, dir(10.0, 120.0))),
            0.0
        );
        let at = g.candela(Scalar, &Vec3s::splat(Scalar, dir(77.0, 45.0)));
        assert!((at - 8.0).abs() < 1e-2, "rotational symmetry: {at}");
    }
}
