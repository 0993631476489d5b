//! Cube-map layouts: the six faces of a cube map (storage order +X, -X, +Y, -Y, +Z, -Z, face
//! axes in [`super::cubemap`]) placed in one image, each face in one S x S cell of a grid and
//! turned as the layout says. A layout only moves texels: to and from a layout is exact.
//!
//! ```text
//! HorizontalCross 4:3       VerticalCross 3:4       Dice 4:3                Horizon 6:1
//!      +--+                      +--+                    +--+               +--+--+--+--+--+--+
//!      |+Y|                      |+Y|                    |+Y| y            |-Z|+X|+Z|-X|+Y|-Y|
//!   +--+--+--+--+             +--+--+--+              +--+--+--+--+        |x |x |x |x |y |y |
//!   |-X|+Z|+X|-Z|             |-X|+Z|+X|              |-X|-Z|+X|+Z|        +--+--+--+--+--+--+
//!   +--+--+--+--+             +--+--+--+              |x |x |x |x |         F  R  B  L  U  D
//!      |-Y|                      |-Y|                 +--+--+--+--+
//!      +--+                      +--+                    |-Y| y            Strip 6:1
//!                                |-Z| (180)              +--+               +--+--+--+--+--+--+
//!                                +--+                                       |+X|-X|+Y|-Y|+Z|-Z|
//!                                                                           +--+--+--+--+--+--+
//! SkylibsCube 3:4
//!      +--+
//!      |+Y| y
//!   +--+--+--+
//!   |-X|-Z|+X|
//!   |x |x |x |
//!   +--+--+--+
//!      |-Y| y
//!      +--+
//!      |+Z| y
//!      +--+
//! ```
//!
//! (`x`: the face mirrored left-right, `y`: top-bottom, `(180)`: both, i.e. turned by 180
//! degrees; unmarked: as stored.) Cells without a face are 0 when a layout is written and are
//! not read.
//!
//! - `HorizontalCross`, `VerticalCross`: cmft's `imageCrossFromCubemap` /
//!   `imageCubemapFromCross` (the same cells as Filament's `CubemapUtils::setFaceFromCross`):
//!   faces as stored, except the vertical cross's -Z, flipped in x and y. With hdrflow's face
//!   data, which is the KTX2 data `Save` writes, they are the crosses cmft writes from that
//!   `.ktx2`. They are views from OUTSIDE the cube in hdrflow's right-handed axes (image right x
//!   image down = minus the face's outward axis): the lat-long map seen in a mirror, with +Z (the
//!   lat-long's back, its left and right edges) in the centre.
//! - `Dice`, `Horizon`: py360convert's `cube_format="dice"` and `"horizon"` (version 1.0.4,
//!   `utils.cube_h2dice`, `xyzcube`): faces F R B L U D, defined from its equirectangular
//!   convention (`u = atan2(x, z)`, the centre column +z, +x right of it, +y up), which puts the
//!   same lat-long image in hdrflow's axes at x = X, y = Y, z = -Z: F = -Z, R = +X, B = +Z,
//!   L = -X, U = +Y, D = -Y. Dice is the view from INSIDE (right x down = the outward axis),
//!   forward in the centre: the unfolded lat-long as seen. It is also what cmft's horizontal
//!   cross of the same lat-long image holds, cmft's lat-long (`vecFromLatLong`) being hdrflow's
//!   with z negated. Horizon has the dice's orientations; py360convert before 1.0 (0.1.0)
//!   stored R and B mirrored left-right and U top-bottom in its horizon (commit a47eb50 made
//!   them the dice's), so an old horizon reads with those three faces mirrored.
//! - `SkylibsCube`: skylibs' `cube` format (`envmap.projections.cube2world` / `world2cube`,
//!   version 0.7.7): up, left, forward, right, down, backward at grid (col, row) (1, 0),
//!   (0, 1), (1, 1), (2, 1), (1, 2), (1, 3). skylibs' axes are hdrflow's (its lat-long,
//!   `world2latlong`, is hdrflow's: -Z at the centre column, +X at 3/4 of the width), so its
//!   faces are the dice's cells, seen from inside with -Z in the centre, except +Z (backward):
//!   below -Y, right +X and down +Y (`u = 1.5 + 0.5 x / z`, `v = 3.5 + 0.5 y / z`), the dice's
//!   +Z turned by 180 degrees, so that it meets -Y along their common edge. skylibs samples a
//!   face at texel centres, as hdrflow does. Read as `VerticalCross`, a skylibs cube has -Z
//!   and +Z swapped and every face mirrored.
//! - `Strip`: hdrflow's own `Save` strip of a cube map: the faces as stored, in storage order.
//!
//! Per cell, the world direction of image right (+u, columns) and image down (+v, rows):
//!
//! ```text
//! face  stored (HorizontalCross, Strip)   VerticalCross   Dice and Horizon
//! +X    right -Z  down -Y                  as stored       right +Z  down -Y   (R)
//! -X    right +Z  down -Y                  as stored       right -Z  down -Y   (L)
//! +Y    right +X  down +Z                  as stored       right +X  down -Z   (U)
//! -Y    right +X  down -Z                  as stored       right +X  down +Z   (D)
//! +Z    right +X  down -Y                  as stored       right -X  down -Y   (B)
//! -Z    right -X  down -Y                  right +X down +Y right +X  down -Y  (F)
//! ```
//!
//! `SkylibsCube` is the dice's column but for +Z: right +X, down +Y.
//!
//! Texel (i, j) of a cell looks along `normalise(n + p r + q d)`, with `n` the face's axis, `r`
//! and `d` the table's right and down, `p = 2 (i + 0.5) / S - 1`, `q = 2 (j + 0.5) / S - 1`
//! (texel centres, as [`super::cubemap`]; py360convert samples its faces at
//! `linspace(-0.5, 0.5, S)`, i.e. its first and last texels sit on the face edges). Tests: the
//! table above against [`super::cubemap`] at every texel, adjacent cells meeting along equal
//! edges, and the dice against py360convert's and cmft's formulas.

crate::choice! {
    /// How the six faces of a cube map sit in one image (see `geometry::cube_layout`).
    pub enum CubeLayout {
        /// 4:3, cmft / Filament: +Y; -X +Z +X -Z; -Y; faces as stored
        HorizontalCross,
        /// 3:4, cmft: +Y; -X +Z +X; -Y; -Z turned 180 degrees
        VerticalCross,
        /// 4:3, py360convert's dice: +Y; -X -Z +X +Z; -Y, the view from inside
        Dice,
        /// 6:1, py360convert's horizon: F R B L U D = -Z +X +Z -X +Y -Y, the dice's orientations
        Horizon,
        /// 6:1, the strip Save writes: +X -X +Y -Y +Z -Z as stored
        Strip,
        /// 3:4, skylibs' cube: +Y; -X -Z +X; -Y; +Z, the view from inside (the dice's faces,
        /// +Z turned 180 degrees below -Y)
        SkylibsCube,
    }
}

crate::choice! {
    /// One face of a cube map, in storage order (cmft names its face files posx, negx, ...).
    pub enum CubeFace { PosX, NegX, PosY, NegY, PosZ, NegZ }
}

impl CubeFace {
    /// The face's index in storage order, 0 (+X) to 5 (-Z).
    pub fn index(self) -> usize {
        self as usize
    }
}

/// How a face is turned in its cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Turn {
    AsStored,
    /// mirrored left-right
    MirrorX,
    /// mirrored top-bottom
    MirrorY,
    /// both: turned by 180 degrees
    Half,
}

impl Turn {
    /// The face texel (x, y) shown at texel (i, j) of a cell of size `size`; a turn is its own
    /// inverse, so this also gives the cell texel of a face texel.
    #[inline]
    pub fn apply(self, i: usize, j: usize, size: usize) -> (usize, usize) {
        let (mx, my) = match self {
            Turn::AsStored => (false, false),
            Turn::MirrorX => (true, false),
            Turn::MirrorY => (false, true),
            Turn::Half => (true, true),
        };
        (if mx { size - 1 - i } else { i }, if my { size - 1 - j } else { j })
    }
}

/// Where one face sits: grid column and row (in faces), and its turn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    pub col: usize,
    pub row: usize,
    pub turn: Turn,
}

const fn cell(col: usize, row: usize, turn: Turn) -> Cell {
    Cell { col, row, turn }
}

use Turn::*;

impl CubeLayout {
    /// The grid in faces: (columns, rows).
    pub fn grid(self) -> (usize, usize) {
        match self {
            CubeLayout::HorizontalCross | CubeLayout::Dice => (4, 3),
            CubeLayout::VerticalCross | CubeLayout::SkylibsCube => (3, 4),
            CubeLayout::Horizon | CubeLayout::Strip => (6, 1),
        }
    }

    /// Each face's cell, in storage order (+X, -X, +Y, -Y, +Z, -Z).
    pub fn cells(self) -> [Cell; 6] {
        match self {
            CubeLayout::HorizontalCross => [
                cell(2, 1, AsStored),
                cell(0, 1, AsStored),
                cell(1, 0, AsStored),
                cell(1, 2, AsStored),
                cell(1, 1, AsStored),
                cell(3, 1, AsStored),
            ],
            CubeLayout::VerticalCross => [
                cell(2, 1, AsStored),
                cell(0, 1, AsStored),
                cell(1, 0, AsStored),
                cell(1, 2, AsStored),
                cell(1, 1, AsStored),
                cell(1, 3, Half),
            ],
            CubeLayout::Dice => [
                cell(2, 1, MirrorX),
                cell(0, 1, MirrorX),
                cell(1, 0, MirrorY),
                cell(1, 2, MirrorY),
                cell(3, 1, MirrorX),
                cell(1, 1, MirrorX),
            ],
            CubeLayout::Horizon => [
                cell(1, 0, MirrorX),
                cell(3, 0, MirrorX),
                cell(4, 0, MirrorY),
                cell(5, 0, MirrorY),
                cell(2, 0, MirrorX),
                cell(0, 0, MirrorX),
            ],
            CubeLayout::Strip => [
                cell(0, 0, AsStored),
                cell(1, 0, AsStored),
                cell(2, 0, AsStored),
                cell(3, 0, AsStored),
                cell(4, 0, AsStored),
                cell(5, 0, AsStored),
            ],
            CubeLayout::SkylibsCube => [
                cell(2, 1, MirrorX),
                cell(0, 1, MirrorX),
                cell(1, 0, MirrorY),
                cell(1, 2, MirrorY),
                cell(1, 3, MirrorY),
                cell(1, 1, MirrorX),
            ],
        }
    }

    /// The image size (width, height) of this layout for faces of `size` texels.
    pub fn image_size(self, size: usize) -> (usize, usize) {
        let (c, r) = self.grid();
        (c * size, r * size)
    }

    /// The face size of a `width` x `height` image of this layout, or why it is not one: it
    /// must be exactly `columns x rows` whole faces (4:3, 3:4 or 6:1) of at least 1 texel.
    pub fn face_size(self, width: usize, height: usize) -> Result<usize, String> {
        let (c, r) = self.grid();
        let s = width / c;
        if s >= 1 && width == c * s && height == r * s {
            return Ok(s);
        }
        Err(format!(
            "a {self} image is {c} faces wide and {r} high ({c}:{r}, e.g. {} x {} for 256-texel faces); this one is {width} x {height}",
            c * 256,
            r * 256
        ))
    }

    /// The face (storage index) whose cell is at grid column `col`, row `row`, if any.
    pub fn face_at(self, col: usize, row: usize) -> Option<usize> {
        self.cells().iter().position(|c| c.col == col && c.row == row)
    }
}

#[cfg(test)]
mod tests {
    use super::super::cubemap::{centre, face_direction, orient};
    use super::*;
    use glam::DVec3;

    const X: DVec3 = DVec3::X;
    const Y: DVec3 = DVec3::Y;
    const Z: DVec3 = DVec3::Z;

    /// The module doc's table: (axis, right, down) of each face's cell, storage order.
    fn frames(layout: CubeLayout) -> [(DVec3, DVec3, DVec3); 6] {
        let stored = [(X, -Z, -Y), (-X, Z, -Y), (Y, X, Z), (-Y, X, -Z), (Z, X, -Y), (-Z, -X, -Y)];
        match layout {
            CubeLayout::HorizontalCross | CubeLayout::Strip => stored,
            CubeLayout::VerticalCross => {
                let mut f = stored;
                f[5] = (-Z, X, Y);
                f
            }
            CubeLayout::Dice | CubeLayout::Horizon => {
                [(X, Z, -Y), (-X, -Z, -Y), (Y, X, -Z), (-Y, X, Z), (Z, -X, -Y), (-Z, X, -Y)]
            }
            CubeLayout::SkylibsCube => [(X, Z, -Y), (-X, -Z, -Y), (Y, X, -Z), (-Y, X, Z), (Z, X, Y), (-Z, X, -Y)],
        }
    }

    /// Direction at continuous cell coordinates (p, q) in [-1, 1] of face `f`'s cell.
    fn cell_dir(layout: CubeLayout, f: usize, p: f64, q: f64) -> DVec3 {
        let (n, r, d) = frames(layout)[f];
        (n + p * r + q * d).normalize()
    }

    #[test]
    fn the_table_is_the_placement_at_every_texel() {
        for layout in CubeLayout::ALL {
            for s in [1, 2, 5] {
                for (f, c) in layout.cells().iter().enumerate() {
                    assert_eq!(layout.face_at(c.col, c.row), Some(f));
                    for j in 0..s {
                        for i in 0..s {
                            let (x, y) = c.turn.apply(i, j, s);
                            assert_eq!(c.turn.apply(x, y, s), (i, j), "a turn is its own inverse");
                            let want = cell_dir(layout, f, centre(i, s), centre(j, s));
                            let got = face_direction(f, centre(x, s), centre(y, s));
                            assert!((got - want).length() < 1e-15, "{layout} face {f} ({i}, {j})");
                        }
                    }
                }
            }
        }
    }

    /// Adjacent cells of every layout but the strips meet along the same directions, and the
    /// crosses are seen from outside, the dice, horizon and skylibs' cube from inside.
    #[test]
    fn cells_meet_along_equal_edges_and_handedness() {
        for layout in
            [CubeLayout::HorizontalCross, CubeLayout::VerticalCross, CubeLayout::Dice, CubeLayout::SkylibsCube]
        {
            let (cols, rows) = layout.grid();
            let mut meetings = 0;
            for row in 0..rows {
                for col in 0..cols {
                    let Some(a) = layout.face_at(col, row) else { continue };
                    for t in [-1.0, -0.3, 0.8] {
                        if let Some(b) = layout.face_at(col + 1, row) {
                            assert!((cell_dir(layout, a, 1.0, t) - cell_dir(layout, b, -1.0, t)).length() < 1e-15);
                            meetings += 1;
                        }
                        if let Some(b) = layout.face_at(col, row + 1) {
                            assert!((cell_dir(layout, a, t, 1.0) - cell_dir(layout, b, t, -1.0)).length() < 1e-15);
                            meetings += 1;
                        }
                    }
                }
            }
            assert_eq!(meetings, 3 * 5, "{layout}: the five folds of the unfolded cube");
        }
        for layout in CubeLayout::ALL {
            let inside = matches!(layout, CubeLayout::Dice | CubeLayout::Horizon | CubeLayout::SkylibsCube);
            for (n, r, d) in frames(layout) {
                assert_eq!(r.cross(d), if inside { n } else { -n }, "{layout}");
            }
        }
        // The horizon strip: F R B L meet like the dice's middle row.
        let h = CubeLayout::Horizon;
        for (a, b) in [(5, 0), (0, 4), (4, 1)] {
            assert!((cell_dir(h, a, 1.0, 0.2) - cell_dir(h, b, -1.0, 0.2)).length() < 1e-15);
        }
    }

    /// py360convert 1.0.4 `xyzcube` (faces F R B L U D; x, y from `meshgrid(rng, -rng)`, the
    /// flips it applies) and `cube_h2dice` cells, in its axes; hdrflow's axes are (x, y, -z).
    /// Continuous face coordinates (p right, q down, in [-1, 1]) instead of its `linspace`.
    #[test]
    fn dice_and_horizon_are_py360converts() {
        let py360 = |face: usize, p: f64, q: f64| -> DVec3 {
            let (x, y) = (p * 0.5, -q * 0.5);
            let v = match face {
                0 => DVec3::new(x, y, 0.5),
                1 => DVec3::new(0.5, y, -x),
                2 => DVec3::new(-x, y, -0.5),
                3 => DVec3::new(-0.5, y, x),
                4 => DVec3::new(x, 0.5, -y),
                _ => DVec3::new(x, -0.5, y),
            };
            DVec3::new(v.x, v.y, -v.z).normalize()
        };
        let dice_cells = [(1, 1), (2, 1), (3, 1), (0, 1), (1, 0), (1, 2)];
        for (k, &(col, row)) in dice_cells.iter().enumerate() {
            let f = CubeLayout::Dice.face_at(col, row).unwrap();
            let h = CubeLayout::Horizon.face_at(k, 0).unwrap();
            for (p, q) in [(0.0, 0.0), (-1.0, -1.0), (0.7, -0.2), (1.0, 0.4)] {
                assert!((cell_dir(CubeLayout::Dice, f, p, q) - py360(k, p, q)).length() < 1e-15, "dice {k}");
                assert!((cell_dir(CubeLayout::Horizon, h, p, q) - py360(k, p, q)).length() < 1e-15, "horizon {k}");
            }
        }
    }

    /// cmft's horizontal cross of a lat-long image holds, at every point, the lat-long point that
    /// hdrflow's dice holds there: cmft's faces (`s_faceUvVectors`, the OpenGL table) in cmft's
    /// lat-long (`vecFromLatLong`: (-sin t sin p, cos t, -sin t cos p)) against hdrflow's.
    #[test]
    fn dice_is_cmfts_cross_of_the_same_latlong() {
        use super::super::latlong::direction;
        use std::f64::consts::{PI, TAU};
        // cmft's lat-long (u, v) of its direction d: u = (pi + atan2(x, z)) / 2 pi, v = acos(y) / pi.
        let cmft_uv = |d: DVec3| ((PI + d.x.atan2(d.z)) / TAU, d.y.acos() / PI);
        for (f, c) in CubeLayout::HorizontalCross.cells().iter().enumerate() {
            let dice_face = CubeLayout::Dice.face_at(c.col, c.row).unwrap();
            for (p, q) in [(0.0, 0.0), (-0.9, -0.9), (0.6, -0.3), (0.95, 0.5)] {
                let (u, v) = cmft_uv(orient(f, DVec3::new(p, q, 1.0)).normalize());
                // The lat-long point (u, v) in hdrflow's convention.
                let seen = DVec3::from(direction(v * PI, u * TAU));
                let dice = cell_dir(CubeLayout::Dice, dice_face, p, q);
                assert!((seen - dice).length() < 1e-12, "cell ({}, {}): {seen} vs {dice}", c.col, c.row);
            }
        }
    }

    /// skylibs 0.7.7 `envmap.projections.cube2world` at continuous grid coordinates (u in [0, 3],
    /// v in [0, 4], v down), its lat-long `latlong2world` being hdrflow's `latlong::direction`.
    #[test]
    fn skylibs_cube_is_skylibs_cube2world() {
        use super::super::latlong::direction;
        use std::f64::consts::{PI, TAU};
        let cube2world = |u: f64, v: f64| -> DVec3 {
            let d = match ((u.floor() as i32).min(2), (v.floor() as i32).min(3)) {
                (1, 0) => DVec3::new((u - 1.5) * 2.0, 1.0, (v - 0.5) * -2.0),
                (0, 1) => DVec3::new(-1.0, (v - 1.5) * -2.0, (u - 0.5) * -2.0),
                (1, 1) => DVec3::new((u - 1.5) * 2.0, (v - 1.5) * -2.0, -1.0),
                (2, 1) => DVec3::new(1.0, (v - 1.5) * -2.0, (u - 2.5) * 2.0),
                (1, 2) => DVec3::new((u - 1.5) * 2.0, -1.0, (v - 2.5) * 2.0),
                (1, 3) => DVec3::new((u - 1.5) * 2.0, (v - 3.5) * 2.0, 1.0),
                cell => panic!("no face at {cell:?}"),
            };
            d.normalize()
        };
        let latlong2world = |u: f64, v: f64| {
            let (t, p) = (PI * (2.0 * u - 1.0), PI * v);
            DVec3::new(p.sin() * t.sin(), p.cos(), -p.sin() * t.cos())
        };
        for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.75, 0.3), (0.93, 0.81)] {
            let d = DVec3::from(direction(v * PI, u * TAU));
            assert!((latlong2world(u, v) - d).length() < 1e-15, "({u}, {v})");
        }
        let layout = CubeLayout::SkylibsCube;
        for (f, c) in layout.cells().iter().enumerate() {
            for (p, q) in [(0.0, 0.0), (-0.99, -0.99), (0.6, -0.3), (0.95, 0.5), (-0.2, 0.99)] {
                let (u, v) = (c.col as f64 + (p + 1.0) / 2.0, c.row as f64 + (q + 1.0) / 2.0);
                let want = cube2world(u, v);
                assert!((cell_dir(layout, f, p, q) - want).length() < 1e-15, "face {f} at ({u}, {v})");
            }
        }
    }

    #[test]
    fn sizes_and_their_errors() {
        assert_eq!(CubeLayout::HorizontalCross.image_size(8), (32, 24));
        assert_eq!(CubeLayout::VerticalCross.face_size(24, 32), Ok(8));
        assert_eq!(CubeLayout::Horizon.face_size(6, 1), Ok(1));
        for (layout, w, h) in [
            (CubeLayout::HorizontalCross, 24, 32),
            (CubeLayout::HorizontalCross, 34, 24),
            (CubeLayout::Dice, 3, 2),
            (CubeLayout::VerticalCross, 0, 0),
            (CubeLayout::Strip, 13, 2),
            (CubeLayout::Horizon, 12, 3),
        ] {
            let e = layout.face_size(w, h).unwrap_err();
            assert!(e.contains(&format!("{w} x {h}")) && e.contains(layout.name()), "{e}");
        }
        assert_eq!(CubeFace::from_name("NegY").map(CubeFace::index), Some(3));
    }
}
