use super::*;
use proptest::prelude::*;
use vme_map::layout::CSPACE_SIDE;
use vme_map::GlobalBus;

fn disk(x_mm: f64, y_mm: f64, r_mm: f64) -> Disk {
    Disk {
        x_um: (x_mm * 1e3) as i32,
        y_um: (y_mm * 1e3) as i32,
        r_um: (r_mm * 1e3) as i32,
    }
}

#[test]
fn the_database_covers_every_disk_up_to_two_inches() {
    assert!(!FAMILIES.is_empty());
    for w in FAMILIES.windows(2) {
        assert!(
            w[0].disk_r_um < w[1].disk_r_um,
            "families by increasing radius"
        );
    }
    assert!(family(25_400).is_ok(), "the thesis's 2-inch obstacles");
    assert_eq!(family(1_000_000), Err(Error::TooLarge));
    assert_eq!(family(-1), Err(Error::BadRadius));
}

#[test]
fn regions_of_fig_iv_7() {
    let kinds = |x_mm: f64| {
        let im = images(&disk(x_mm, 0.0, 0.0)).unwrap();
        (
            im.stripe.map(|s| s.full),
            im.front.is_some(),
            im.rear.is_some(),
        )
    };
    // Region I: everything; II: link 1 and front; III: all three; IV: front and rear;
    // V: front only; VI: nothing.
    assert_eq!(kinds(30.0), (Some(true), false, false));
    assert_eq!(kinds(100.0), (Some(false), true, false));
    assert_eq!(kinds(200.0), (Some(false), true, true));
    assert_eq!(kinds(330.0), (None, true, true));
    assert_eq!(kinds(450.0), (None, true, false));
    assert_eq!(kinds(530.0), (None, false, false));
}

#[test]
fn images_are_odd_symmetric_and_shift_with_the_polar_angle() {
    let a = images(&disk(350.0, 0.0, 25.4)).unwrap().front.unwrap();
    for k in 0..CHAIN {
        assert_eq!(a.theta1_u[k], -a.theta1_u[CHAIN - 1 - k]);
        assert_eq!(a.upper_u[k], -a.lower_u[CHAIN - 1 - k]);
    }
    // 45 degrees: the same image moved 4096 units along the diagonal (fig. IV.9), to within
    // the polar conversion's rounding.
    let c = 350.0 / 2f64.sqrt();
    let b = images(&disk(c, c, 25.4)).unwrap().front.unwrap();
    for k in 0..CHAIN {
        assert!((b.theta1_u[k] - a.theta1_u[k] - 4096).abs() <= 2);
        assert!((b.upper_u[k] - a.upper_u[k] - 4096).abs() <= 2);
    }
}

#[test]
fn an_image_across_the_seam_of_the_torus_is_drawn_on_both_sides() {
    // A disk behind the shoulder (polar angle pi): its images straddle theta1 = +-pi.
    let mut h = Memory::default();
    let im = images(&disk(-400.0, 0.0, 25.4)).unwrap();
    apply(&im, &mut h.canvas(), Op::Draw);
    let col = |i1: u32| (0..128).any(|i2| h.occupied(i1, i2));
    assert!(col(63) && col(64), "both sides of theta1 = pi");
    assert!(!col(0), "nothing at theta1 = 0");
    apply(&im, &mut h.canvas(), Op::Erase);
    assert!(h.is_clear());
}

#[test]
fn region_i_fills_the_stripe_layer_only() {
    let mut h = Memory::default();
    let im = images(&disk(10.0, 5.0, 10.0)).unwrap();
    apply(&im, &mut h.canvas(), Op::Draw);
    assert!(h.stripes.iter().all(|&w| w == counters::ALL));
    assert!(
        h.map.iter().all(|&w| w == 0),
        "16384 pixels cost 128 stripe words"
    );
}

#[test]
fn edge_normals_point_out_of_the_image() {
    // The front image of a disk on the x axis: its top rows count +theta2, its bottom rows
    // -theta2, its inside all four.
    let mut h = Memory::default();
    let im = images(&disk(450.0, 0.0, 25.4)).unwrap();
    raster::shape(im.front.as_ref().unwrap(), &mut h.canvas(), Op::Draw);
    let (mut top, mut bottom, mut inside) = (0, 0, 0);
    for i1 in 0..128 {
        let col: Vec<(usize, u32)> = (0..128)
            .map(|i2| (i2, h.map[i2 * 128 + i1]))
            .filter(|&(_, w)| w != 0)
            .collect();
        if col.len() < 3 || col.len() > 60 {
            continue;
        }
        // Unwrap around theta2 = 0 for the ordering.
        let key = |i2: usize| if i2 >= 64 { i2 as i32 - 128 } else { i2 as i32 };
        let hi = col.iter().max_by_key(|c| key(c.0)).unwrap().1;
        let lo = col.iter().min_by_key(|c| key(c.0)).unwrap().1;
        top += (hi & counters::P2 != 0) as u32;
        bottom += (lo & counters::M2 != 0) as u32;
        inside += col.iter().filter(|c| c.1 == counters::ALL).count();
    }
    assert!(
        top > 5 && bottom > 5 && inside > 5,
        "{top} {bottom} {inside}"
    );
}

#[test]
fn counters_saturate_and_report_instead_of_wrapping() {
    let mut h = Memory::default();
    let im = images(&disk(450.0, 0.0, 25.4)).unwrap();
    let mut flags = Flags::default();
    for _ in 0..300 {
        flags.merge(apply(&im, &mut h.canvas(), Op::Draw));
    }
    assert!(flags.saturated);
    for _ in 0..300 {
        apply(&im, &mut h.canvas(), Op::Erase);
    }
    assert!(
        !h.is_clear(),
        "saturated counters stay set: the pixels stay occupied rather than open a void"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Draw-new-before-erase-old over random moves of several obstacles, then a final erase:
    /// the map is all zero again (thesis lines ~1199-1210), and at no step is a pixel that
    /// the current images cover found free.
    #[test]
    fn moves_then_erase_leave_the_map_clear(
        moves in prop::collection::vec((0usize..3, -520_000i32..520_000, -520_000i32..520_000, 0i32..25_400), 1..12)
    ) {
        let mut h = Memory::default();
        let mut at: [Option<Images>; 3] = [None; 3];
        for (k, x, y, r) in moves {
            let new = images(&Disk { x_um: x, y_um: y, r_um: r }).unwrap();
            apply(&new, &mut h.canvas(), Op::Draw);
            // The new image is in place before the old one goes.
            let mut only = Memory::default();
            apply(&new, &mut only.canvas(), Op::Draw);
            for i2 in 0..128 {
                for i1 in 0..128 {
                    prop_assert!(!only.occupied(i1, i2) || h.occupied(i1, i2));
                }
            }
            if let Some(old) = at[k].replace(new) {
                let f = apply(&old, &mut h.canvas(), Op::Erase);
                prop_assert_eq!(f, Flags::default());
            }
        }
        for im in at.iter().flatten() {
            apply(im, &mut h.canvas(), Op::Erase);
        }
        prop_assert!(h.is_clear());
    }
}

/// Global RAM on a byte slice, as the native simulation and the boards see the map.
fn bus_map(global: &mut [u8]) -> (Vec<u32>, Vec<u32>) {
    use vme_map::layout::{CSPACE_MAP, CSPACE_STRIPES};
    let mut g = vme_map::ArrayBus::new(global);
    let map = (0..CSPACE_SIDE * CSPACE_SIDE)
        .map(|i| g.read_u32(CSPACE_MAP + 4 * i))
        .collect();
    let stripes = (0..CSPACE_SIDE)
        .map(|i| g.read_u32(CSPACE_STRIPES + 4 * i))
        .collect();
    (map, stripes)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// The map in global RAM (runs of plain words in one bus call, the others byte by byte)
    /// gets exactly the counters and flags of the map in memory (pixel by pixel), with
    /// counters started near saturation and at zero, drawing and erasing.
    #[test]
    fn runs_on_the_bus_match_pixel_by_pixel_updates(
        x in -500.0f64..500.0, y in -500.0f64..500.0, r in 0.0f64..50.0,
        seed in any::<u64>(), erase_first in any::<bool>(),
    ) {
        use vme_map::layout::{CSPACE_MAP, CSPACE_STRIPES};
        let Ok(im) = images(&disk(x, y, r)) else { return Ok(()); };
        // The same scattered start: zeros, small counts, bytes at 127..255.
        let mut mem = Memory::default();
        let mut global = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
        let mut s = seed | 1;
        for (i, w) in mem.map.iter_mut().enumerate() {
            s ^= s << 13; s ^= s >> 7; s ^= s << 17;
            *w = match s % 8 {
                0 => (s >> 8) as u32 | 0x7F7F_7F7F,
                1 => 0x0101_0101,
                2 => 0x00FE_0001,
                _ => 0,
            };
            vme_map::ArrayBus::new(&mut global).write_u32(CSPACE_MAP + 4 * i as u32, *w);
        }
        for (i, w) in mem.stripes.iter().enumerate() {
            vme_map::ArrayBus::new(&mut global).write_u32(CSPACE_STRIPES + 4 * i as u32, *w);
        }
        let ops = if erase_first { [Op::Erase, Op::Draw] } else { [Op::Draw, Op::Erase] };
        for op in ops {
            let a = apply(&im, &mut mem.canvas(), op);
            let b = apply(&im, &mut BusCanvas(&mut vme_map::ArrayBus::new(&mut global)), op);
            prop_assert_eq!(a, b);
            let (map, stripes) = bus_map(&mut global);
            prop_assert!(map == mem.map.to_vec(), "maps differ after {:?}", op);
            prop_assert!(stripes == mem.stripes.to_vec());
        }
    }
}

/// Moves `old`'s link-2 images to `new`'s on `h` as the boards do ([`raster::pair`], the
/// log's decrements after every increment), checking after the first half that every pixel
/// either image covers is occupied. `fill` runs pushed into the log first leave room for
/// `room` runs only (the log then overflows and the second half is computed again).
fn moved(h: &mut Memory, old: &Images, new: &Images, room: usize) -> Result<Flags, TestCaseError> {
    let mut log = raster::RunLog::new();
    while raster::LOG_WORDS - log.len() > room {
        assert!(log.push(0, 0, 1, 0));
    }
    let filler = log.len();
    let mut cur = raster::PairWork::new();
    let mut f = Flags::default();
    let mut pairs = [(old.front, new.front), (old.rear, new.rear)];
    let mut logged = [true; 2];
    for (k, (o, n)) in pairs.iter_mut().enumerate() {
        let (fl, ok) = raster::pair(o, n, &mut h.canvas(), Some(&mut log), &mut cur);
        f.merge(fl);
        logged[k] = ok;
    }
    let mut both = Memory::default();
    for im in [old, new] {
        let only = Images {
            stripe: None,
            ..*im
        };
        apply(&only, &mut both.canvas(), Op::Draw);
    }
    for i2 in 0..128 {
        for i1 in 0..128 {
            prop_assert!(
                !both.occupied(i1, i2) || h.occupied(i1, i2),
                "({}, {}) free between the halves",
                i1,
                i2
            );
        }
    }
    // The filler runs decrement nothing (no counters).
    f.merge(log.erase(&mut h.canvas()));
    prop_assert!(filler == 0 || log.len() >= filler);
    for (k, (o, n)) in pairs.iter_mut().enumerate() {
        if !logged[k] {
            let (fl, _) = raster::pair(o, n, &mut h.canvas(), None, &mut cur);
            f.merge(fl);
        }
    }
    Ok(f)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// The differential update of a moved obstacle (small moves, large ones, across the
    /// torus's seam, into and out of regions, with a full log) leaves exactly the counters
    /// that drawing the new images and erasing the old ones leaves, and opens no void
    /// between its halves.
    #[test]
    fn differential_moves_match_draw_then_erase(
        x in -520_000i32..520_000, y in -520_000i32..520_000, r in 0i32..50_000,
        dx in -3_000i32..3_000, dy in -3_000i32..3_000, far in any::<bool>(),
        other in (-520_000i32..520_000, -520_000i32..520_000), room in prop_oneof![Just(raster::LOG_WORDS), 0usize..40],
    ) {
        let (nx, ny) = if far { (-y, x) } else { (x + dx, y + dy) };
        let (Ok(old), Ok(new)) = (
            images(&Disk { x_um: x, y_um: y, r_um: r }),
            images(&Disk { x_um: nx, y_um: ny, r_um: r + dx.abs() % 700 }),
        ) else { return Ok(()); };
        // Another obstacle's images underneath: counts above one where they overlap.
        let mut h = Memory::default();
        if let Ok(o) = images(&Disk { x_um: other.0, y_um: other.1, r_um: 25_400 }) {
            apply(&o, &mut h.canvas(), Op::Draw);
        }
        apply(&old, &mut h.canvas(), Op::Draw);
        let mut want = h.clone();
        let only = |im: &Images| Images { stripe: None, ..*im };
        apply(&only(&new), &mut want.canvas(), Op::Draw);
        apply(&only(&old), &mut want.canvas(), Op::Erase);
        // `h` holds the old images (stripe too): move the link-2 ones.
        let f = moved(&mut h, &old, &new, room)?;
        prop_assert_eq!(f, Flags::default());
        prop_assert!(h.map == want.map, "the maps differ");
    }
}

/// Near the elbow's circle a 2-inch obstacle's front image spans more than a revolution of
/// theta2 in its middle columns, before and after a 1 mm move (the C-space bench's worst
/// case): the differential update writes nothing in those columns although their first
/// rows moved (each gives every row all four counters once), and the map is still what
/// drawing the new images and erasing the old ones leaves.
#[test]
fn full_columns_whose_first_rows_moved_are_left_alone() {
    /// A canvas that counts the pixels written in each map column.
    struct Counting<'a> {
        inner: raster::SliceCanvas<'a>,
        per_col: [u32; 128],
    }
    impl raster::Canvas for Counting<'_> {
        fn pixel(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags {
            self.per_col[i1 as usize] += 1;
            self.inner.pixel(i1, i2, mask, op)
        }
        fn stripe(&mut self, i1: u32, mask: u32, op: Op) -> Flags {
            self.inner.stripe(i1, mask, op)
        }
    }
    let mut skipped = 0;
    for mm in 236..=264 {
        let disk = |x_um| Disk {
            x_um,
            y_um: 0,
            r_um: 28_500,
        };
        let (old, new) = (
            images(&disk(mm * 1000)).unwrap(),
            images(&disk(mm * 1000 + 1000)).unwrap(),
        );
        // The map columns full in both images whose first rows differ.
        let columns = |im: &Images| {
            let mut v = Vec::new();
            let c = raster::each_column(&im.front.unwrap(), |w| v.push(w));
            (c.0, v)
        };
        let ((oc, o), (nc, n)) = (columns(&old), columns(&new));
        let mut full_moved = Vec::new();
        for (i, w) in n.iter().enumerate() {
            let j = i as i32 + nc - oc;
            if let Some(was) = usize::try_from(j).ok().and_then(|j| o.get(j)) {
                if w[2] == 128 && was[2] == 128 && w[1] != was[1] {
                    full_moved.push(w[0] as usize);
                }
            }
        }
        let mut h = Memory::default();
        apply(&old, &mut h.canvas(), Op::Draw);
        let mut want = h.clone();
        let only = |im: &Images| Images {
            stripe: None,
            ..*im
        };
        apply(&only(&new), &mut want.canvas(), Op::Draw);
        apply(&only(&old), &mut want.canvas(), Op::Erase);
        let mut work = raster::PairWork::new();
        let mut log = raster::RunLog::new();
        let (mut of, mut or) = (old.front, old.rear);
        let per_col = {
            let mut c = Counting {
                inner: h.canvas(),
                per_col: [0; 128],
            };
            let (f, ok) = raster::pair(&mut of, &new.front, &mut c, Some(&mut log), &mut work);
            assert!(ok && f == Flags::default());
            assert_eq!(log.erase(&mut c), Flags::default());
            c.per_col
        };
        let mut log = raster::RunLog::new();
        let (f, ok) = raster::pair(
            &mut or,
            &new.rear,
            &mut h.canvas(),
            Some(&mut log),
            &mut work,
        );
        assert!(ok && f == Flags::default());
        assert_eq!(log.erase(&mut h.canvas()), Flags::default());
        assert!(h.map == want.map, "the maps differ at {mm} mm");
        for &c in &full_moved {
            assert_eq!(per_col[c], 0, "{mm} mm: column {c} written");
        }
        skipped += full_moved.len();
    }
    assert!(
        skipped > 20,
        "only {skipped} full columns whose first rows moved"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Jobs on the work list by two boards (one doing most, the other now and then), small
    /// moves and jumps: after every job the map holds exactly the image of the entry's
    /// recorded position (the differential moves leave nothing of the old images).
    #[test]
    fn jobs_leave_the_image_of_the_recorded_position(
        start in (-450_000i32..450_000, -450_000i32..450_000),
        moves in prop::collection::vec((-4_000i32..4_000, -4_000i32..4_000, 0u8..8), 1..16),
    ) {
        use vme_map::records::{beacon_flags, ObjectTable};
        let mut global = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
        let mut boards = [Box::new(worklist::Scratch::new()), Box::new(worklist::Scratch::new())];
        let (mut x, mut y) = start;
        for (k, &(dx, dy, how)) in moves.iter().enumerate() {
            // Mostly small moves; now and then a jump across the map.
            (x, y) = if how == 0 { (-y, x) } else { (x + dx, y + dy) };
            let mut t = ObjectTable { frame: k as u32 + 1, ..Default::default() };
            let b = &mut t.beacons[worklist::OBSTACLE_BEACONS[0] as usize];
            (b.x_um, b.y_um, b.t_us, b.flags) = (x, y, 1_000 * (k as u32 + 1), beacon_flags::VALID);
            // One round of the cursor (six entries); board 1 takes it now and then.
            let board = usize::from(how == 1);
            for _ in 0..worklist::OBSTACLE_BEACONS.len() {
                let mut g = vme_map::ArrayBus::new(&mut global);
                let out = worklist::step(&mut g, 1 + board as u32, &t, &mut boards[board]);
                prop_assert_eq!(out.flags, Flags::default());
                prop_assert!(out.error.is_none());
            }
            let e = worklist::entry(&mut vme_map::ArrayBus::new(&mut global), 0);
            let mut want = Memory::default();
            if let Ok(im) = images(&worklist::drawn_disk(e.x_um, e.y_um, e.r_um, 0)) {
                apply(&im, &mut want.canvas(), Op::Draw);
            }
            let (map, stripes) = bus_map(&mut global);
            prop_assert!(map == want.map.to_vec(), "map after move {}", k);
            prop_assert!(stripes == want.stripes.to_vec(), "stripes after move {}", k);
        }
    }
}

/// The calibrated square the fold tests write into the calibration header (the model's).
const AREA_UM: [i32; 4] = [-350_000, 350_000, -350_000, 350_000];

#[test]
fn only_extrapolated_readings_fold_and_only_past_the_sides_they_lie_beyond() {
    use vme_map::records::beacon_flags::{EXTRAPOLATED, VALID};
    let f = |x, y, flags| worklist::fold_of(x, y, flags, &AREA_UM);
    // Inside, or outside without the flag: no fold.
    assert_eq!(f(0, 0, VALID | EXTRAPOLATED), 0);
    assert_eq!(f(450_000, 0, VALID), 0);
    // One bit a side.
    assert_eq!(f(450_000, 0, VALID | EXTRAPOLATED), 1 << 1);
    assert_eq!(f(-450_000, 10_000, VALID | EXTRAPOLATED), 1 << 2);
    assert_eq!(f(0, 400_000, VALID | EXTRAPOLATED), 1 << 3);
    assert_eq!(f(-5_000, -360_000, VALID | EXTRAPOLATED), 1 << 4);
    assert_eq!(
        f(360_000, -360_000, VALID | EXTRAPOLATED),
        (1 << 1) | (1 << 4)
    );
    // The folded disk of no fold is the disk as read.
    let d = worklist::folded(1, 2, 3, 0);
    assert_eq!((d.x_um, d.y_um, d.r_um), (1, 2, 3));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// The folded disk holds a disk of the same radius anywhere along the fold (outward
    /// from the reading to REACH_UM + r, at most FOLD_MAX_UM, past one side;
    /// FOLD_CORNER_UM along both past a corner) and up to FOLD_SIDE_UM across it.
    #[test]
    fn the_folded_disk_covers_the_fold(
        side in 0u8..8, along in -349_000i32..349_000, past in 1i32..200_000,
        r in 1_000i32..40_000, a in 0.0f64..=1.0, b in 0.0f64..=1.0, l in -1.0f64..=1.0,
    ) {
        use vme_map::records::beacon_flags::{EXTRAPOLATED, VALID};
        // A reading past one side (0-3) or a corner (4-7).
        let out = 350_000 + past;
        let (x, y) = match side {
            0 => (out, along), 1 => (-out, along), 2 => (along, out), 3 => (along, -out),
            4 => (out, out), 5 => (-out, out), 6 => (out, -out), _ => (-out, -out),
        };
        let bits = worklist::fold_of(x, y, VALID | EXTRAPOLATED, &AREA_UM);
        let d = worklist::folded(x, y, r, bits);
        let (sx, sy) = (x.signum() as f64, y.signum() as f64);
        let side_um = worklist::FOLD_SIDE_UM as f64 * l;
        let (tx, ty) = if side < 4 {
            let at = if side < 2 { x.abs() } else { y.abs() };
            let reach = (worklist::REACH_UM + r - at).clamp(0, worklist::FOLD_MAX_UM);
            let f = reach as f64 * a;
            match side {
                0 | 1 => (x as f64 + sx * f, y as f64 + side_um),
                _ => (x as f64 + side_um, y as f64 + sy * f),
            }
        } else {
            let f = worklist::FOLD_CORNER_UM as f64;
            (x as f64 + sx * f * a + side_um * core::f64::consts::FRAC_1_SQRT_2, y as f64 + sy * f * b - side_um * core::f64::consts::FRAC_1_SQRT_2)
        };
        let reach = (tx - d.x_um as f64).hypot(ty - d.y_um as f64) + r as f64;
        prop_assert!(reach <= d.r_um as f64, "{reach} beyond {}", d.r_um);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// Jobs on readings that go in and out of the calibrated square, flagged extrapolated
    /// beyond it: after every job the map holds exactly the image of the entry's recorded
    /// position folded as recorded, a reading that moved by more than `MOVE_UM` is
    /// recorded, and one whose fold changed is redrawn at once (however little it moved).
    #[test]
    fn jobs_draw_an_extrapolated_reading_over_its_fold(
        start in (300_000i32..420_000, -200_000i32..200_000),
        moves in prop::collection::vec((-30_000i32..30_000, -30_000i32..30_000), 1..12),
    ) {
        use vme_map::records::{beacon_flags, cal, ObjectTable};
        let mut global = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
        {
            use vme_map::GlobalBus;
            let mut g = vme_map::ArrayBus::new(&mut global);
            for (k, &v) in AREA_UM.iter().enumerate() {
                g.write_u32(vme_map::layout::SENSING_CAL + 4 * (cal::W_AREA + k as u32), v as u32);
            }
        }
        let mut sc = Box::new(worklist::Scratch::new());
        let (mut x, mut y) = start;
        // The position the entry records: the reading's after every redraw, which a move of
        // at most MOVE_UM each way does not bring unless the fold changed.
        let (mut at, mut was_fold): (Option<(i32, i32)>, u32) = (None, 0);
        for (k, &(dx, dy)) in moves.iter().enumerate() {
            (x, y) = (x + dx, y + dy);
            let beyond = x.abs() > AREA_UM[1] + 5_000 || y.abs() > AREA_UM[3] + 5_000;
            let mut t = ObjectTable { frame: k as u32 + 1, ..Default::default() };
            let b = &mut t.beacons[worklist::OBSTACLE_BEACONS[0] as usize];
            let flags = beacon_flags::VALID | if beyond { beacon_flags::EXTRAPOLATED } else { 0 };
            (b.x_um, b.y_um, b.t_us, b.flags) = (x, y, 1_000 * (k as u32 + 1), flags);
            for _ in 0..worklist::OBSTACLE_BEACONS.len() {
                let mut g = vme_map::ArrayBus::new(&mut global);
                let out = worklist::step(&mut g, 1, &t, &mut sc);
                prop_assert_eq!(out.flags, Flags::default());
                prop_assert!(out.error.is_none(), "{:?}", out.error);
            }
            let e = worklist::entry(&mut vme_map::ArrayBus::new(&mut global), 0);
            let fold = e.state & worklist::FOLD_MASK;
            let new_fold = worklist::fold_of(x, y, flags, &AREA_UM);
            let redrawn = match at {
                None => true,
                Some((ax, ay)) => {
                    (x - ax).abs() > worklist::MOVE_UM
                        || (y - ay).abs() > worklist::MOVE_UM
                        || new_fold != was_fold
                }
            };
            if redrawn {
                (at, was_fold) = (Some((x, y)), new_fold);
            }
            prop_assert_eq!(fold, was_fold, "fold after move {}", k);
            prop_assert_eq!(Some((e.x_um, e.y_um)), at, "position after move {}", k);
            let mut want = Memory::default();
            let d = worklist::drawn_disk(e.x_um, e.y_um, e.r_um, fold);
            if let Ok(im) = images(&d) {
                apply(&im, &mut want.canvas(), Op::Draw);
            }
            let (map, stripes) = bus_map(&mut global);
            prop_assert!(map == want.map.to_vec(), "map after move {}", k);
            prop_assert!(stripes == want.stripes.to_vec(), "stripes after move {}", k);
        }
    }
}

/// Global RAM that counts, between two writes of work-list entry 0's claim word (a job's
/// progress marks), the map and stripe words written, and keeps the most.
struct MarkWatch<'a> {
    ram: vme_map::ArrayBus<'a>,
    since_mark: u32,
    most: u32,
    marks: u32,
    /// The words entry 0 was claimed with.
    claims: Vec<u32>,
}

impl<'a> MarkWatch<'a> {
    /// Watching `global`, nothing counted yet.
    fn new(global: &'a mut [u8]) -> Self {
        MarkWatch {
            ram: vme_map::ArrayBus::new(global),
            since_mark: 0,
            most: 0,
            marks: 0,
            claims: Vec::new(),
        }
    }
}

impl GlobalBus for MarkWatch<'_> {
    fn read_u32(&mut self, off: u32) -> u32 {
        self.ram.read_u32(off)
    }
    fn write_u32(&mut self, off: u32, val: u32) {
        use vme_map::layout::{work_entry, CSPACE_MAP, CSPACE_STRIPES};
        if off == work_entry(0) {
            self.marks += 1;
            self.since_mark = 0;
        } else if off >= CSPACE_MAP
            || (CSPACE_STRIPES..CSPACE_STRIPES + 4 * CSPACE_SIDE).contains(&off)
        {
            self.since_mark += 1;
            self.most = self.most.max(self.since_mark);
        }
        self.ram.write_u32(off, val)
    }
    fn read_u8(&mut self, off: u32) -> u8 {
        self.ram.read_u8(off)
    }
    fn write_u8(&mut self, off: u32, val: u8) {
        self.ram.write_u8(off, val)
    }
    fn cas_u32(&mut self, off: u32, current: u32, new: u32) -> u32 {
        let found = self.ram.cas_u32(off, current, new);
        if off == vme_map::layout::work_entry(0) && found == current {
            self.claims.push(new);
        }
        found
    }
}

/// A job marks its progress while it writes, not only between images: a moving obstacle's
/// swept images are large, and a job on them as images outlasted the reflex's 20 ms for an
/// entry claimed and unchanged (`moving_obstacles.toml` held the arm 22 times in 2 s). At
/// most eight column-level writes (128 words each at most) go between two marks.
#[test]
fn a_job_marks_its_progress_while_it_draws() {
    use vme_map::records::{beacon_flags, ObjectTable};
    let mut global = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
    let mut sc = Box::new(worklist::Scratch::new());
    // A 40 mm obstacle moving across the elbow's circle: drawn, then moved 60 mm, swept.
    for (k, (x, flags)) in [
        (230_000, beacon_flags::VALID),
        (290_000, beacon_flags::VALID | beacon_flags::MOVING),
    ]
    .into_iter()
    .enumerate()
    {
        let mut t = ObjectTable {
            frame: k as u32 + 1,
            ..Default::default()
        };
        let b = &mut t.beacons[worklist::OBSTACLE_BEACONS[0] as usize];
        (b.x_um, b.y_um, b.t_us, b.flags) = (x, 20_000, 100_000 * (k as u32 + 1), flags);
        vme_map::ArrayBus::new(&mut global).write_u32(vme_map::layout::OBSTACLE_RADII, 40_000);
        let mut watch = MarkWatch::new(&mut global);
        // One round of the cursor: entry 0's job among the others'.
        for _ in 0..worklist::OBSTACLE_BEACONS.len() {
            let out = worklist::step(&mut watch, 1, &t, &mut sc);
            assert!(out.error.is_none(), "{out:?}");
        }
        assert!(watch.marks > 4, "job {k}: {} marks", watch.marks);
        assert!(
            watch.most <= 8 * 128,
            "job {k}: {} words between two marks",
            watch.most
        );
    }
}

/// Consecutive jobs on an entry claim it with different words, even when neither draws
/// (the reflex reads an entry every few milliseconds and takes a claim word unchanged for
/// 20 ms for an abandoned job: two jobs that both showed board 1's bare number looked like
/// one that stood still).
#[test]
fn consecutive_jobs_on_an_entry_claim_it_with_different_words() {
    use vme_map::records::{beacon_flags, ObjectTable};
    let mut global = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
    let mut sc = Box::new(worklist::Scratch::new());
    let mut t = ObjectTable {
        frame: 1,
        ..Default::default()
    };
    let b = &mut t.beacons[worklist::OBSTACLE_BEACONS[0] as usize];
    (b.x_um, b.y_um, b.t_us, b.flags) = (200_000, 0, 1_000, beacon_flags::VALID);
    vme_map::ArrayBus::new(&mut global).write_u32(vme_map::layout::OBSTACLE_RADII, 25_000);
    let mut watch = MarkWatch::new(&mut global);
    // Three rounds of the cursor with the same table: the first job draws, the others
    // find nothing to do.
    for _ in 0..3 * worklist::OBSTACLE_BEACONS.len() {
        worklist::step(&mut watch, 1, &t, &mut sc);
    }
    let c = &watch.claims;
    assert_eq!(c.len(), 3, "{c:x?}");
    assert!(c.iter().all(|w| w & 0xFF == 1), "{c:x?}");
    assert!(c[0] != c[1] && c[1] != c[2] && c[0] != c[2], "{c:x?}");
}
