//! Wall following on the planner's blocked cells (thesis ch. VI section 4, algorithm step 2):
//! a bug that keeps the wall on one side, moving one cell (4-connected) at a time: toward
//! the wall if it can, else straight, else away, else back. The same tracer leads the arm
//! (its cell is the request to the reflex) and, run ahead on the bitmap alone, scouts both
//! ways round an obstacle before the arm commits to one (beyond the thesis, which always
//! turned right).

use crate::grid::Grid;

/// What one step found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Moved along the wall.
    Moved,
    /// On the M-line from the hit point to the goal, nearer the goal than the hit point,
    /// with the way toward the goal open: a leave point.
    Leave,
    /// At the goal's cell.
    AtGoal,
    /// Back at the hit point (on the torus) without a leave point.
    Cycle,
    /// No wall on its side any more (four turns toward it in a row: circling free space).
    Lost,
    /// Boxed in: no free neighbour.
    Stuck,
}

/// The four directions: +theta1, +theta2, -theta1, -theta2.
#[inline(always)]
pub fn step_of(dir: u32) -> [i32; 2] {
    match dir & 3 {
        0 => [1, 0],
        1 => [0, 1],
        2 => [-1, 0],
        _ => [0, -1],
    }
}

#[inline(always)]
fn add(a: [i32; 2], b: [i32; 2]) -> [i32; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

/// Squared distance in cells.
#[inline(always)]
pub fn d2(a: [i32; 2], b: [i32; 2]) -> i32 {
    let (x, y) = (a[0] - b[0], a[1] - b[1]);
    x * x + y * y
}

/// One step from `c` toward `g` along the axis with more to go (sign masks, no compare
/// and branch: docs/toolchain.md).
#[inline(always)]
pub fn toward(c: [i32; 2], g: [i32; 2]) -> [i32; 2] {
    use reflex::masks::{abs, lt, pick};
    let (x, y) = (g[0] - c[0], g[1] - c[1]);
    let sign = |v: i32| (v >> 31) | ((v.wrapping_neg() as u32) >> 31) as i32;
    let ymajor = lt(abs(x), abs(y));
    [
        c[0] + pick(ymajor, 0, sign(x)),
        c[1] + pick(ymajor, sign(y), 0),
    ]
}

/// Cross product of (goal - hit) and (c - hit): which side of the M-line `c` is on.
#[inline(always)]
fn cross(hit: [i32; 2], goal: [i32; 2], c: [i32; 2]) -> i32 {
    let (dx, dy) = (goal[0] - hit[0], goal[1] - hit[1]);
    let (cx, cy) = (c[0] - hit[0], c[1] - hit[1]);
    dx * cy - dy * cx
}

/// Dot product of (goal - hit) and (c - hit): whether `c` is ahead of the hit point.
#[inline(always)]
fn dot(hit: [i32; 2], goal: [i32; 2], c: [i32; 2]) -> i32 {
    let (dx, dy) = (goal[0] - hit[0], goal[1] - hit[1]);
    let (cx, cy) = (c[0] - hit[0], c[1] - hit[1]);
    dx * cx + dy * cy
}

/// A bug following a wall.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tracer {
    /// Its cell (unwrapped).
    pub bug: [i32; 2],
    /// Its heading.
    pub dir: u32,
    /// 1: wall on the left (positive circulation); 3: on the right.
    pub side: u32,
    toward_wall: u32,
    left_hit: bool,
    prev_cross: i32,
    /// Steps taken.
    pub steps: u32,
}

impl Tracer {
    /// A bug that has not started (at the origin, wall to +theta1 on its left).
    pub const IDLE: Tracer = Tracer {
        bug: [0; 2],
        dir: 3,
        side: 1,
        toward_wall: 0,
        left_hit: false,
        prev_cross: 0,
        steps: 0,
    };

    /// A bug at `at` with the wall in direction `wall`, on side `side` (1 left, 3 right).
    pub fn new(at: [i32; 2], wall: u32, side: u32, hit: [i32; 2], goal: [i32; 2]) -> Self {
        Self {
            bug: at,
            dir: (wall + 4 - side) & 3,
            side,
            toward_wall: 0,
            left_hit: false,
            prev_cross: cross(hit, goal, at),
            steps: 0,
        }
    }

    /// One step along the wall, and what it found (hit point `hit` at squared distance
    /// `hit_d2` from `goal`).
    #[inline(never)]
    pub fn step(&mut self, g: &Grid, hit: [i32; 2], hit_d2: i32, goal: [i32; 2]) -> Event {
        let s = self.side;
        let mut k = 0;
        let mut moved = false;
        while k < 4 {
            // Toward the wall, straight, away, back.
            let d = match k {
                0 => (self.dir + s) & 3,
                1 => self.dir,
                2 => (self.dir + 4 - s) & 3,
                _ => (self.dir + 2) & 3,
            };
            let c = add(self.bug, step_of(d));
            if g.blocked(c) == 0 {
                self.toward_wall = if k == 0 { self.toward_wall + 1 } else { 0 };
                self.dir = d;
                self.bug = c;
                moved = true;
                break;
            }
            k += 1;
        }
        if !moved {
            return Event::Stuck;
        }
        self.steps += 1;
        if self.toward_wall >= 4 {
            return Event::Lost;
        }
        let b = self.bug;
        if b == goal {
            return Event::AtGoal;
        }
        let away = [(b[0] - hit[0]).abs(), (b[1] - hit[1]).abs()];
        if away[0].max(away[1]) >= 3 {
            self.left_hit = true;
        }
        let x = cross(hit, goal, b);
        let crossed = (x == 0) || ((x > 0) != (self.prev_cross > 0));
        self.prev_cross = x;
        if crossed
            && dot(hit, goal, b) > 0
            && d2(b, goal) < hit_d2
            && g.blocked(toward(b, goal)) == 0
        {
            return Event::Leave;
        }
        // Back at the hit point on the torus (also after going once round it).
        let w = [(b[0] - hit[0]) & 127, (b[1] - hit[1]) & 127];
        let near = |d: i32| d <= 1 || d >= 127;
        if self.left_hit && near(w[0]) && near(w[1]) {
            return Event::Cycle;
        }
        Event::Moved
    }

    /// The wall-lost search: the wall where it was last felt, up to `cells` ahead. Returns
    /// whether it was found (the bug then stands beside it).
    pub fn relocate(&mut self, g: &Grid, cells: i32) -> bool {
        let wall = (self.dir + self.side) & 3;
        let mut c = self.bug;
        let mut n = 0;
        while n < cells {
            let next = add(c, step_of(wall));
            if g.blocked(next) != 0 {
                self.bug = c;
                self.toward_wall = 0;
                self.dir = (wall + 4 - self.side) & 3;
                return true;
            }
            c = next;
            n += 1;
        }
        false
    }
}
