//! Rectangles binned into a grid of square cells, and convex polygons as half-planes.

/// Axis-aligned rectangles `[x_min, x_max, y_min, y_max]` binned by the cells they overlap:
/// the rectangles that may hold a point are those of its cell.
#[derive(Debug, Clone)]
pub(super) struct Bins {
    x0: f32,
    y0: f32,
    cell: f32,
    nx: usize,
    ny: usize,
    /// Cell `i`'s rectangles are `items[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl Bins {
    /// Bins `rects` (at least one) into cells of side `cell`.
    pub(super) fn new(rects: &[[f32; 4]], cell: f32) -> Self {
        let x0 = rects.iter().map(|r| r[0]).fold(f32::INFINITY, f32::min);
        let x1 = rects.iter().map(|r| r[1]).fold(f32::NEG_INFINITY, f32::max);
        let y0 = rects.iter().map(|r| r[2]).fold(f32::INFINITY, f32::min);
        let y1 = rects.iter().map(|r| r[3]).fold(f32::NEG_INFINITY, f32::max);
        let nx = ((x1 - x0) / cell).floor() as usize + 1;
        let ny = ((y1 - y0) / cell).floor() as usize + 1;
        let mut bins = Self { x0, y0, cell, nx, ny, offsets: Vec::new(), items: Vec::new() };
        // Counting pass, then filling (compressed rows: one allocation for all cells).
        let mut counts = vec![0u32; nx * ny + 1];
        for r in rects {
            bins.for_cells(*r, |i| counts[i + 1] += 1);
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        bins.offsets = counts.clone();
        bins.items = vec![0u32; counts[nx * ny] as usize];
        for (k, r) in rects.iter().enumerate() {
            let items = &mut bins.items;
            let (x0, y0, cell, nx, ny) = (x0, y0, cell, nx, ny);
            for_cells_of(x0, y0, cell, (nx, ny), *r, |i| {
                items[counts[i] as usize] = k as u32;
                counts[i] += 1;
            });
        }
        bins
    }

    fn for_cells(&self, r: [f32; 4], f: impl FnMut(usize)) {
        for_cells_of(self.x0, self.y0, self.cell, (self.nx, self.ny), r, f);
    }

    /// The rectangles binned in the cell holding `(x, y)` (none outside the grid).
    #[inline]
    pub(super) fn at(&self, x: f32, y: f32) -> &[u32] {
        let (a, b) = ((x - self.x0) / self.cell, (y - self.y0) / self.cell);
        if !(a >= 0.0 && b >= 0.0) {
            return &[];
        }
        let (i, j) = (a as usize, b as usize);
        if i >= self.nx || j >= self.ny {
            return &[];
        }
        let c = j * self.nx + i;
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }

    /// Whether some rectangle binned in a cell that `r` overlaps makes `f` true.
    pub(super) fn any_over(&self, r: [f32; 4], mut f: impl FnMut(u32) -> bool) -> bool {
        let mut found = false;
        self.for_cells(r, |c| {
            if !found {
                found = self.cell(c).iter().any(|&k| f(k));
            }
        });
        found
    }

    fn cell(&self, c: usize) -> &[u32] {
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }

    /// Calls `f` with every rectangle binned in a cell that the segment from `a` to `b` passes
    /// through (a rectangle binned in several such cells comes several times): the cells are
    /// walked in order along the segment (Amanatides and Woo's traversal).
    pub(super) fn along(&self, a: [f32; 2], b: [f32; 2], mut f: impl FnMut(u32)) {
        // Clip the segment to the grid first.
        let (x1, y1) = (self.x0 + self.nx as f32 * self.cell, self.y0 + self.ny as f32 * self.cell);
        let d = [b[0] - a[0], b[1] - a[1]];
        let (mut t0, mut t1) = (0.0f32, 1.0f32);
        for (k, (lo, hi)) in [(self.x0, x1), (self.y0, y1)].into_iter().enumerate() {
            if d[k] == 0.0 {
                if a[k] < lo || a[k] > hi {
                    return;
                }
            } else {
                let (u, v) = ((lo - a[k]) / d[k], (hi - a[k]) / d[k]);
                t0 = t0.max(u.min(v));
                t1 = t1.min(u.max(v));
            }
        }
        if t0 > t1 {
            return;
        }
        let start = [a[0] + t0 * d[0], a[1] + t0 * d[1]];
        let index =
            |v: f32, lo: f32, n: usize| (((v - lo) / self.cell).max(0.0) as usize).min(n - 1);
        let (mut i, mut j) = (index(start[0], self.x0, self.nx), index(start[1], self.y0, self.ny));
        let (i_end, j_end) = {
            let end = [a[0] + t1 * d[0], a[1] + t1 * d[1]];
            (index(end[0], self.x0, self.nx), index(end[1], self.y0, self.ny))
        };
        // Parameter (over the whole segment) of the next vertical and horizontal cell border.
        let border = |k: usize, cell_index: usize, lo: f32| {
            if d[k] > 0.0 {
                ((lo + (cell_index + 1) as f32 * self.cell) - a[k]) / d[k]
            } else if d[k] < 0.0 {
                ((lo + cell_index as f32 * self.cell) - a[k]) / d[k]
            } else {
                f32::INFINITY
            }
        };
        let step = [self.cell / d[0].abs(), self.cell / d[1].abs()];
        let (mut next_x, mut next_y) = (border(0, i, self.x0), border(1, j, self.y0));
        // At most one cell per border crossed, plus the first: a bound that rounding cannot
        // turn into an endless walk.
        for _ in 0..=(i.abs_diff(i_end) + j.abs_diff(j_end) + 2) {
            self.cell(j * self.nx + i).iter().for_each(|&k| f(k));
            if i == i_end && j == j_end {
                return;
            }
            if next_x < next_y {
                if d[0] > 0.0 && i + 1 < self.nx {
                    i += 1;
                } else if d[0] < 0.0 && i > 0 {
                    i -= 1;
                } else {
                    return;
                }
                next_x += step[0];
            } else {
                if d[1] > 0.0 && j + 1 < self.ny {
                    j += 1;
                } else if d[1] < 0.0 && j > 0 {
                    j -= 1;
                } else {
                    return;
                }
                next_y += step[1];
            }
        }
    }

    /// Entries over all cells.
    pub(super) fn entries(&self) -> usize {
        self.items.len()
    }
}

/// Calls `f` with the index of every cell of the `n` grid (origin `x0, y0`, side `cell`) that
/// rectangle `r` overlaps, clamped to the grid.
fn for_cells_of(
    x0: f32,
    y0: f32,
    cell: f32,
    (nx, ny): (usize, usize),
    r: [f32; 4],
    mut f: impl FnMut(usize),
) {
    let index = |v: f32, lo: f32, n: usize| (((v - lo) / cell).max(0.0) as usize).min(n - 1);
    let (i0, i1) = (index(r[0], x0, nx), index(r[1], x0, nx));
    let (j0, j1) = (index(r[2], y0, ny), index(r[3], y0, ny));
    for j in j0..=j1 {
        for i in i0..=i1 {
            f(j * nx + i);
        }
    }
}

/// Most points [`Polygon::hull`] takes.
pub(super) const MAX_POINTS: usize = 16;

/// A convex polygon of the plane as the half-planes `a·x + b·y ≤ c` of its edges.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Polygon {
    planes: [[f32; 3]; MAX_POINTS],
    n: usize,
}

impl Polygon {
    /// The convex hull of `points` (at most [`MAX_POINTS`]; Andrew's monotone chain).
    pub(super) fn hull(points: &[[f32; 2]]) -> Self {
        let mut buffer = [[0.0f32; 2]; MAX_POINTS];
        let p = &mut buffer[..points.len()];
        p.copy_from_slice(points);
        p.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        let cross = |o: [f32; 2], a: [f32; 2], b: [f32; 2]| {
            (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
        };
        // Lower hull left to right, then upper hull right to left, each without its last point.
        let mut hull = [[0.0f32; 2]; 2 * MAX_POINTS + 2];
        let mut len = 0;
        for pass in 0..2 {
            let start = len;
            for &q in p.iter() {
                while len >= start + 2 && cross(hull[len - 2], hull[len - 1], q) <= 0.0 {
                    len -= 1;
                }
                hull[len] = q;
                len += 1;
            }
            len -= 1;
            if pass == 0 {
                p.reverse();
            }
        }
        let hull = &hull[..len];
        // Counter-clockwise: inside is to the left of every edge.
        let mut planes = [[0.0f32; 3]; MAX_POINTS];
        let n = hull.len().min(MAX_POINTS);
        for i in 0..n {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            let (nx, ny) = (b[1] - a[1], a[0] - b[0]);
            planes[i] = [nx, ny, nx * a[0] + ny * a[1]];
        }
        Self { planes, n }
    }

    /// The interval of `s` in `[lo, hi]` over which `origin + s·dir` lies inside, if any.
    #[inline]
    pub(super) fn clip(
        &self,
        origin: [f32; 2],
        dir: [f32; 2],
        lo: f32,
        hi: f32,
    ) -> Option<(f32, f32)> {
        let (mut lo, mut hi) = (lo, hi);
        for &[a, b, c] in &self.planes[..self.n] {
            let at0 = a * origin[0] + b * origin[1] - c;
            let rate = a * dir[0] + b * dir[1];
            if rate == 0.0 {
                if at0 > 0.0 {
                    return None;
                }
            } else if rate > 0.0 {
                hi = hi.min(-at0 / rate);
            } else {
                lo = lo.max(-at0 / rate);
            }
        }
        (lo < hi).then_some((lo, hi))
    }

    /// The half-planes `[a, b, c]` (`a·x + b·y ≤ c` inside).
    pub(crate) fn planes(&self) -> &[[f32; 3]] {
        &self.planes[..self.n]
    }

    /// Whether the polygon may overlap rectangle `r` (`[x_min, x_max, y_min, y_max]`): false
    /// only where one of its edges' half-planes leaves the whole rectangle outside.
    pub(super) fn overlaps(&self, r: [f32; 4]) -> bool {
        self.n >= 3
            && self.planes[..self.n].iter().all(|&[a, b, c]| {
                // The rectangle's corner deepest into the half-plane.
                let x = if a > 0.0 { r[0] } else { r[1] };
                let y = if b > 0.0 { r[2] } else { r[3] };
                a * x + b * y <= c
            })
    }

    /// Whether `p` lies inside (edges included).
    pub(super) fn contains(&self, p: [f32; 2]) -> bool {
        self.planes[..self.n].iter().all(|&[a, b, c]| a * p[0] + b * p[1] <= c)
    }
}
