//! The six panels of the paper's figure 2, drawn from a 2D fit: how the error metric E of
//! section 4.3 finds where the next constraints go.
//!
//! ```text
//! (a) goal shape, with the constraints   (b) contour at an early      (c) contour at the next
//!     added between (b) and (c) as dots      iteration                    iteration
//! (d) signed distance of (a), with the   (e) signed distance of (b),  (f) the final contour
//!     contour of (b) over it                 with the boundary of (a)
//! ```
//!
//! The dots on (a) are magenta for the boundary constraints, found along the goal's boundary
//! on (e), as in the paper, and cyan for the interior and exterior constraints, found along the
//! contour on (d), which the paper does not show.
//!
//! As in the paper, contour panels are black inside (positive values) and white outside;
//! signed distances are red where positive and blue where negative, darker further from 0
//! (darkest at the largest value of that sign on either panel). Each panel shows the fit's 2D
//! grid at `scale` picture pixels per grid pixel, y up; the implicit functions are evaluated at
//! every picture pixel, so their contours are as smooth as the functions, and the signed
//! distances and the goal's densities are interpolated bilinearly. Panels are separated and
//! framed by a grey band [`GAP`] pixels wide and labelled (a) to (f) in their top-left corner.

use implicitize::fit::Goal;
use implicitize::rbf::{self, Implicit};
use implicitize::render::Image;
use implicitize::{DVec3, Error, Field, Result, edt, grid::Grid, grid::Volume};

/// The width of the grey bands between and around panels, in picture pixels.
pub const GAP: usize = 6;

/// The largest picture accepted along a side, in pixels.
pub const MAX_SIDE: usize = 8192;

const GREY: [u8; 4] = [150, 150, 150, 255];
const BLACK: [u8; 4] = [0, 0, 0, 255];
const WHITE: [u8; 4] = [255, 255, 255, 255];
const MAGENTA: [u8; 4] = [230, 0, 230, 255];
const CYAN: [u8; 4] = [0, 200, 230, 255];

/// The models the figure is drawn from, all fitted to the same 2D goal.
#[derive(Debug, Clone, Copy)]
pub struct Snapshots<'a> {
    /// The contour of panels (b) and (d), and the signed distance of (e).
    pub early: &'a Implicit,
    /// The contour of panel (c), the iteration after `early`.
    pub next: &'a Implicit,
    /// The contour of panel (f), the fit's final model.
    pub last: &'a Implicit,
}

/// Which two iterations (1-based) panels (b) and (c) show for a fit of `iterations`
/// iterations: 3 and 4 as in the paper, or the first two of a shorter fit (1 and 1 for a fit
/// of one iteration).
pub fn early_iterations(iterations: usize) -> (usize, usize) {
    if iterations >= 4 { (3, 4) } else { (1, 2.min(iterations.max(1))) }
}

/// The size (width, height) of the figure of a goal on `grid` at `scale`.
pub fn size(grid: &Grid, scale: usize) -> (usize, usize) {
    let (w, h) = (grid.dims[0] * scale, grid.dims[1] * scale);
    (3 * w + 4 * GAP, 2 * h + 3 * GAP)
}

/// Checks that the figure of a goal on `grid` can be drawn at `scale`: the grid is 2D, `scale`
/// is not 0, and the picture is at most [`MAX_SIDE`] pixels along a side.
pub fn check(grid: &Grid, scale: usize) -> Result<()> {
    if !grid.is_2d() {
        return Err(Error::invalid("figure 2", "the goal is not on a 2D grid"));
    }
    let (width, height) = size(grid, scale);
    if scale == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(Error::invalid(
            "figure 2",
            format!("a {width} x {height} picture at scale {scale} is not drawable"),
        ));
    }
    Ok(())
}

/// Draws figure 2 for `goal` (a 2D goal) and the `snapshots` of its fit, at `scale` picture
/// pixels per grid pixel.
///
/// Fails where [`check`] does.
pub fn draw(goal: &Goal, snapshots: &Snapshots, scale: usize) -> Result<Image> {
    let grid = *goal.grid();
    check(&grid, scale)?;
    let (width, height) = size(&grid, scale);
    let panel = Panel::new(grid, scale);
    let inside = |values: &[f64]| values.iter().map(|&v| v > 0.0).collect::<Vec<bool>>();
    let early = inside(&panel.values(snapshots.early));
    let goal_inside: Vec<bool> =
        panel.grid_points().iter().map(|&g| edt::sample(goal.density(), g) > 0.5).collect();
    let early_sd = current_signed_distance(snapshots.early, goal);
    let range = Range::of(goal.sd()).union(Range::of(&early_sd));

    let mut a = panel.contour(&goal_inside);
    for (p, value) in added_constraints(snapshots.early, snapshots.next) {
        panel.dot(&mut a, p, if value == 0.0 { MAGENTA } else { CYAN });
    }
    let b = panel.contour(&early);
    let c = panel.contour(&inside(&panel.values(snapshots.next)));
    let mut d = panel.signed_distance(goal.sd(), range);
    panel.outline(&mut d, &early);
    let mut e = panel.signed_distance(&early_sd, range);
    panel.outline(&mut e, &goal_inside);
    let f = panel.contour(&inside(&panel.values(snapshots.last)));

    let mut figure = Image { width, height, rgba: GREY.repeat(width * height) };
    for (n, picture) in [a, b, c, d, e, f].iter().enumerate() {
        let (column, row) = (n % 3, n / 3);
        let left = GAP + column * (panel.width + GAP);
        let top = GAP + row * (panel.height + GAP);
        paste(&mut figure, picture, left, top);
        label(&mut figure, n, left + 3, top + 3);
    }
    Ok(figure)
}

/// sd_curr of `implicit` on the goal's grid, as the fit measures it.
fn current_signed_distance(implicit: &Implicit, goal: &Goal) -> Volume<f32> {
    let values = rbf::evaluate_on_grid(implicit, goal.grid(), Some(goal.sd()));
    let inside = Volume { grid: values.grid, data: values.data.iter().map(|&v| v > 0.0).collect() };
    edt::signed_distance(&inside)
}

/// The largest positive value and the largest magnitude of a negative one (at least 1 each):
/// where the colours of [`diverging`] are darkest.
#[derive(Debug, Clone, Copy)]
struct Range {
    positive: f32,
    negative: f32,
}

impl Range {
    fn of(sd: &Volume<f32>) -> Range {
        let finite = || sd.data.iter().filter(|v| v.is_finite());
        Range {
            positive: finite().fold(1.0f32, |m, &v| m.max(v)),
            negative: finite().fold(1.0f32, |m, &v| m.max(-v)),
        }
    }

    fn union(self, other: Range) -> Range {
        Range {
            positive: self.positive.max(other.positive),
            negative: self.negative.max(other.negative),
        }
    }
}

/// The positions (model units) and values of the constraints of `next` that `early` lacks.
fn added_constraints(early: &Implicit, next: &Implicit) -> Vec<(DVec3, f64)> {
    next.constraints()
        .iter()
        .filter(|c| early.constraints().iter().all(|o| o.position() != c.position()))
        .map(|c| {
            let p = c.position();
            (DVec3::new(p[0], p.get(1).copied().unwrap_or(0.0), 0.0), c.value())
        })
        .collect()
}

/// One panel: the 2D grid seen at `scale` picture pixels per grid pixel, y up.
struct Panel {
    grid: Grid,
    scale: usize,
    width: usize,
    height: usize,
}

impl Panel {
    fn new(grid: Grid, scale: usize) -> Panel {
        Panel { grid, scale, width: grid.dims[0] * scale, height: grid.dims[1] * scale }
    }

    /// The continuous grid coordinates of every picture pixel's centre, row by row from the top.
    fn grid_points(&self) -> Vec<DVec3> {
        let s = self.scale as f64;
        let top = (self.grid.dims[1] - 1) as f64;
        (0..self.height)
            .flat_map(|v| {
                (0..self.width).map(move |u| {
                    DVec3::new((u as f64 + 0.5) / s - 0.5, top - ((v as f64 + 0.5) / s - 0.5), 0.0)
                })
            })
            .collect()
    }

    /// The values of `field` at every picture pixel.
    fn values(&self, field: &dyn Field) -> Vec<f64> {
        let points: Vec<DVec3> =
            self.grid_points().into_iter().map(|g| self.grid.to_world(g)).collect();
        field.values(&points)
    }

    /// Black where inside, white elsewhere.
    fn contour(&self, inside: &[bool]) -> Image {
        let rgba = inside.iter().flat_map(|&i| if i { BLACK } else { WHITE }).collect();
        Image { width: self.width, height: self.height, rgba }
    }

    /// A signed distance, red positive and blue negative, darker further from 0 up to `range`.
    fn signed_distance(&self, sd: &Volume<f32>, range: Range) -> Image {
        let rgba =
            self.grid_points().iter().flat_map(|&g| diverging(edt::sample(sd, g), range)).collect();
        Image { width: self.width, height: self.height, rgba }
    }

    /// Draws the boundary between inside and outside pixels as a thin black line.
    fn outline(&self, image: &mut Image, inside: &[bool]) {
        let w = self.width;
        for v in 0..self.height {
            for u in 0..w {
                let here = inside[v * w + u];
                let right = u + 1 < w && inside[v * w + u + 1] != here;
                let below = v + 1 < self.height && inside[(v + 1) * w + u] != here;
                if right || below {
                    set(image, u, v, BLACK);
                }
            }
        }
    }

    /// A disc at the model-units point `p`.
    fn dot(&self, image: &mut Image, p: DVec3, color: [u8; 4]) {
        let g = self.grid.to_grid(p);
        let s = self.scale as f64;
        let top = (self.grid.dims[1] - 1) as f64;
        let (cu, cv) = ((g.x + 0.5) * s - 0.5, (top - g.y + 0.5) * s - 0.5);
        let radius = (0.9 * s).max(3.5);
        let reach = radius.ceil() as isize;
        for dv in -reach..=reach {
            for du in -reach..=reach {
                let (u, v) = (cu.round() as isize + du, cv.round() as isize + dv);
                let (x, y) = (u as f64 - cu, v as f64 - cv);
                if u >= 0 && v >= 0 && x * x + y * y <= radius * radius {
                    set(image, u as usize, v as usize, color);
                }
            }
        }
    }
}

/// Red for positive values, blue for negative, from pale at 0 to dark at the end of `range`
/// on each side (on a square-root scale, so that small distances along the contours show).
fn diverging(value: f32, range: Range) -> [u8; 4] {
    let (pale, dark, end) = if value >= 0.0 {
        ([255.0, 215.0, 215.0], [110.0, 0.0, 0.0], range.positive)
    } else {
        ([215.0, 215.0, 255.0], [0.0, 0.0, 110.0], range.negative)
    };
    let t = if value.is_finite() { (value.abs() / end).clamp(0.0, 1.0).sqrt() } else { 1.0 };
    let mix = |c: usize| (pale[c] + (dark[c] - pale[c]) * t).round() as u8;
    [mix(0), mix(1), mix(2), 255]
}

fn set(image: &mut Image, x: usize, y: usize, color: [u8; 4]) {
    if x < image.width && y < image.height {
        let i = (y * image.width + x) * 4;
        image.rgba[i..i + 4].copy_from_slice(&color);
    }
}

fn paste(figure: &mut Image, picture: &Image, left: usize, top: usize) {
    for (y, row) in picture.rgba.chunks_exact(picture.width * 4).enumerate() {
        let start = ((top + y) * figure.width + left) * 4;
        figure.rgba[start..start + row.len()].copy_from_slice(row);
    }
}

/// The letters a to f, 5 x 7, one row of bits per line, most significant bit leftmost.
const GLYPHS: [[u8; 7]; 6] = [
    [0b00000, 0b00000, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111],
    [0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b11110],
    [0b00000, 0b00000, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110],
    [0b00001, 0b00001, 0b01101, 0b10011, 0b10001, 0b10001, 0b01111],
    [0b00000, 0b00000, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110],
    [0b00110, 0b01001, 0b01000, 0b11100, 0b01000, 0b01000, 0b01000],
];

/// Writes letter number `n` (a, b, ...) at twice its size, dark grey on a light box.
fn label(figure: &mut Image, n: usize, left: usize, top: usize) {
    const SIZE: usize = 2;
    for y in 0..(7 + 2) * SIZE {
        for x in 0..(5 + 2) * SIZE {
            set(figure, left + x, top + y, [235, 235, 235, 255]);
        }
    }
    for (row, bits) in GLYPHS[n].iter().enumerate() {
        for column in 0..5 {
            if bits >> (4 - column) & 1 == 1 {
                for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    let (x, y) = (left + (column + 1) * SIZE + dx, top + (row + 1) * SIZE + dy);
                    set(figure, x, y, [40, 40, 40, 255]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panels_b_and_c_show_iterations_3_and_4_or_the_first_two() {
        assert_eq!(early_iterations(14), (3, 4));
        assert_eq!(early_iterations(4), (3, 4));
        assert_eq!(early_iterations(3), (1, 2));
        assert_eq!(early_iterations(1), (1, 1));
    }

    #[test]
    fn signed_distances_darken_away_from_zero() {
        let range = Range { positive: 10.0, negative: 40.0 };
        let [r0, g0, b0, _] = diverging(0.5, range);
        let [r1, g1, b1, _] = diverging(10.0, range);
        assert!(r0 > b0 && r1 > b1 && g1 < g0 && r1 < r0);
        let [r2, _, b2, _] = diverging(-5.0, range);
        let [r3, _, b3, _] = diverging(-40.0, range);
        assert!(b2 > r2 && b3 > r3 && b3 < b2);
    }
}
