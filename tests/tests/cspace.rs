//! The C-space map against the exact oracle (issue 7): no pixel that holds a colliding
//! configuration is ever left free, and the committed database is what the generator builds
//! from the arm's outline.

use cspace::Disk;
use proptest::prelude::*;
use sim_host::cspace_oracle::{check_disk, pixel, random_disk, survey, Verdict};

#[test]
fn the_committed_database_is_what_the_generator_builds() {
    let text = sim_host::cspace_db::render(&sim_host::cspace_db::build());
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let committed = std::fs::read_to_string(root.join(sim_host::cspace_db::TABLES_PATH)).unwrap();
    assert!(
        text == committed,
        "crates/cspace/src/tables.rs is stale: cargo run -p sim-host -- cspace-db --write"
    );
}

#[test]
fn the_oracle_finds_collisions_and_proves_freedom() {
    // A pin at 45 cm on the x axis: the outstretched arm (pixel 0, 0) hits it; the arm
    // folded back (theta2 = pi) cannot.
    let d = Disk {
        x_um: 450_000,
        y_um: 0,
        r_um: 1_000,
    };
    assert_eq!(pixel(&d, 0, 0), Verdict::Collides);
    assert_eq!(pixel(&d, 0, 64), Verdict::Free);
    assert_eq!(pixel(&d, 64, 0), Verdict::Free);
}

#[test]
fn a_survey_of_random_disks_finds_no_false_free_pixel() {
    let s = survey(7, 200, &|_| {});
    assert_eq!(s.disks, 200);
    assert_eq!(
        s.total.false_free, 0,
        "first offender: {:?}",
        s.first_false_free
    );
    assert!(s.total.exact > 0 && s.total.false_occupied > 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn no_pixel_holding_a_collision_is_free(seed: u64) {
        let d = random_disk(seed, 0);
        let c = check_disk(&d).unwrap();
        prop_assert_eq!(c.false_free, 0, "disk {:?}", d);
    }

    #[test]
    fn no_pixel_holding_a_collision_is_free_near_region_boundaries(
        r_mm in prop::sample::select(vec![38.0, 120.0, 250.0, 275.0, 380.0, 515.0]),
        dr_mm in -8.0f64..8.0,
        phi in -3.2f64..3.2,
        size_mm in 0.0f64..25.4,
    ) {
        let rho = (r_mm + dr_mm) * 1e3;
        let d = Disk {
            x_um: (rho * phi.cos()) as i32,
            y_um: (rho * phi.sin()) as i32,
            r_um: (size_mm * 1e3) as i32,
        };
        let c = check_disk(&d).unwrap();
        prop_assert_eq!(c.false_free, 0, "disk {:?}", d);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// The disk a C-space job draws for a reading (`cspace::worklist::drawn_disk`) holds an
    /// obstacle of the same radius anywhere within the sensing board's tolerance of the
    /// reading (`beacon_flags::TOLERANCE_UM`): no pixel holding a collision with the
    /// obstacle where it is is free. The obstacles' radii are those the database's families
    /// hold with no room to spare, so that only the tolerance can cover the offset. (Drawn
    /// where it was read, a disk 1 mm off left such pixels free next to the arm in the
    /// reflex campaign's static scenes.)
    #[test]
    fn a_reading_off_by_the_sensing_tolerance_still_covers_its_obstacle(
        seed: u64, family in 1usize..6, under in 0i32..300, bearing in -3.2f64..3.2,
        off in 0.5f64..=1.0,
    ) {
        let truth = Disk {
            r_um: cspace::db::FAMILIES[family].disk_r_um - cspace::POLAR_MARGIN_UM - under,
            ..random_disk(seed, 0)
        };
        let tol = vme_map::records::beacon_flags::TOLERANCE_UM as f64;
        // The reading, off by at most the tolerance (each coordinate rounded toward the
        // obstacle keeps it within).
        let toward = |v: f64| v.trunc() as i32;
        let (dx, dy) = (off * tol * bearing.cos(), off * tol * bearing.sin());
        let read = (truth.x_um + toward(dx), truth.y_um + toward(dy));
        let drawn = cspace::worklist::drawn_disk(read.0, read.1, truth.r_um, 0);
        let Ok(im) = cspace::images(&drawn) else { return Ok(()) };
        let mut m = cspace::Memory::default();
        cspace::apply(&im, &mut m.canvas(), cspace::Op::Draw);
        for i2 in 0..128 {
            for i1 in 0..128 {
                prop_assert!(
                    m.occupied(i1, i2) || pixel(&truth, i1, i2) != Verdict::Collides,
                    "({}, {}) free: {:?} read at {:?}", i1, i2, truth, read
                );
            }
        }
    }
}

/// The C-space image on the emulated 68020 computes the same work list, map and stripe layer
/// as the native code, bit for bit, for six obstacles moving through every region of
/// fig. IV.7 (with sweeps and a blinking beacon). Each of the 68k backend miscompiles this
/// caught (a slice loop that ran zero times, every entry reading beacon 0, an array indexed
/// on its own frame, a struct return that overwrote the caller's local) made it fail.
#[test]
fn the_cspace_image_draws_what_the_host_draws() {
    let tables = sim_host::cspace_bench::equivalence_tables(11, 20);
    sim_host::cspace_bench::image_vs_host(&system_tests::images_dir(), &tables).unwrap();
}

/// Requires the map and stripe layer in `global` (global RAM) to be `host`'s, word for word.
fn assert_map_is(global: &[u8], host: &cspace::Memory, what: &str) {
    use vme_map::layout::{CSPACE_MAP, CSPACE_STRIPES};
    let word = |o: u32| {
        let o = o as usize;
        u32::from_be_bytes([global[o], global[o + 1], global[o + 2], global[o + 3]])
    };
    for (i, &w) in host.map.iter().enumerate() {
        assert_eq!(word(CSPACE_MAP + 4 * i as u32), w, "{what}, pixel {i}");
    }
    for (i, &w) in host.stripes.iter().enumerate() {
        assert_eq!(word(CSPACE_STRIPES + 4 * i as u32), w, "{what}, stripe {i}");
    }
}

/// The cspace image's own `images` and raster (called through its test probes on the
/// emulated CPU) against the host's, for random disks: the images' vertices, and the map and
/// stripe layer they draw, bit for bit.
#[test]
fn the_cspace_image_transforms_and_rasterises_like_the_host() {
    let (mut b, img, mut global) = system_tests::board_of(vme_map::BoardId::Cspace0);
    let probe_images = img.symbol("cspace_probe_images").unwrap();
    let probe_draw = img.symbol("cspace_probe_draw").unwrap();
    const BUF: u32 = 0xC0000;
    let word = |m: &[u8], o: usize| u32::from_be_bytes([m[o], m[o + 1], m[o + 2], m[o + 3]]);
    for n in 0..200 {
        let d = random_disk(78, n);
        let args = [d.x_um as u32, d.y_um as u32, d.r_um as u32];
        // The images: stripe, then front and rear (present, wraps, 33 x 3 vertices).
        let (ret, _) = b
            .call(
                &mut global,
                probe_images,
                &[args[0], args[1], args[2], BUF],
                10_000_000,
            )
            .expect("probe returns");
        assert_eq!(ret, 0);
        let im = cspace::images(&d).unwrap();
        let mut want = vec![0i32; 205];
        if let Some(s) = im.stripe {
            want[0..3].copy_from_slice(&[s.lo_u, s.hi_u, s.full as i32]);
        }
        for (base, shape) in [(3, &im.front), (104, &im.rear)] {
            if let Some(s) = shape {
                want[base] = 1;
                want[base + 1] = s.wraps as i32;
                want[base + 2..base + 35].copy_from_slice(&s.theta1_u);
                want[base + 35..base + 68].copy_from_slice(&s.upper_u);
                want[base + 68..base + 101].copy_from_slice(&s.lower_u);
            }
        }
        let got: Vec<i32> = (0..205)
            .map(|i| word(&b.ram, (BUF + 4 * i) as usize) as i32)
            .collect();
        assert_eq!(got, want, "images of {d:?}");
        // The raster, on a clear map.
        global.iter_mut().for_each(|x| *x = 0);
        b.call(&mut global, probe_draw, &args, 100_000_000)
            .expect("probe returns");
        let mut host = cspace::Memory::default();
        cspace::apply(&im, &mut host.canvas(), cspace::Op::Draw);
        assert_map_is(&global, &host, &format!("{d:?}"));
    }
}

/// The image's `__cspace_columns` (the column extents in the runtime's assembly) called
/// directly on the emulated CPU gives, column for column, the words the host's
/// `raster::column` gives: for the images of random disks as they are, and with vertical
/// segments made in them (a vertex moved onto its neighbour's theta1) and spread round
/// theta1 as wrapping images: neither is found among the database's images, so the
/// routine's branches for them are tested only here.
#[test]
fn the_cspace_images_column_extents_match_the_host() {
    let (mut b, img, mut global) = system_tests::board_of(vme_map::BoardId::Cspace0);
    let routine = img.symbol("__cspace_columns").unwrap();
    // The shape at SHAPE (cspace::Shape, repr(C)), the columns at OUT (32 bytes each).
    const SHAPE: u32 = 0xC0000;
    const OUT: u32 = 0xC1000;
    let (mut shapes, mut vertical, mut wrapping) = (0, 0, 0);
    // Random disks, then a 2-inch obstacle every 2 mm out from the shoulder.
    let swept = (20..=260).map(|k| cspace::Disk {
        x_um: 1_732 * k,
        y_um: 1_000 * k,
        r_um: 28_500,
    });
    for (n, disk) in (0..300)
        .map(|n| random_disk(93, n))
        .chain(swept)
        .enumerate()
    {
        let n = n as u64;
        let Ok(im) = cspace::images(&disk) else {
            continue;
        };
        for (i, shape) in [im.front, im.rear].into_iter().enumerate() {
            let Some(mut s) = shape else { continue };
            if n % 3 == 1 {
                // Vertical segments: vertex k + 1 (and for some, k + 2) moved onto vertex k's
                // theta1, at places the disk's digits pick, and the last one.
                let d = random_disk(94, n * 2 + i as u64);
                for pick in [d.x_um, d.y_um] {
                    let k = pick.unsigned_abs() as usize % 32;
                    s.theta1_u[k + 1] = s.theta1_u[k];
                }
                // The walk passes over vertical segments but at the last vertex, where the
                // last column's left edge lies on it when theta1 there ends a pixel: so.
                let end = s.theta1_u[32] | 255;
                s.theta1_u[31] = end;
                s.theta1_u[32] = end;
                vertical += 1;
            } else if n % 3 == 2 {
                // An image all the way round theta1 (none of the database's does): the
                // vertices spread over a revolution.
                let (t0, w) = (s.theta1_u[0], s.theta1_u[32] - s.theta1_u[0]);
                for t in s.theta1_u.iter_mut() {
                    *t = t0 + ((*t - t0) as i64 * 32_768 / w as i64) as i32;
                }
                s.wraps = true;
            }
            wrapping += s.wraps as u32;
            let mut bytes = Vec::with_capacity(400);
            for v in s.theta1_u.iter().chain(&s.upper_u).chain(&s.lower_u) {
                bytes.extend_from_slice(&v.to_be_bytes());
            }
            bytes.push(s.wraps as u8);
            b.ram[SHAPE as usize..SHAPE as usize + bytes.len()].copy_from_slice(&bytes);
            let mut want = Vec::new();
            let (c0, c1) = cspace::raster::each_column(&s, |w| want.push(w));
            let args = [SHAPE, c0 as u32, c1 as u32, OUT];
            b.call(&mut global, routine, &args, 10_000_000)
                .expect("the routine returns");
            let word = |o: usize| {
                let o = OUT as usize + 4 * o;
                u32::from_be_bytes([b.ram[o], b.ram[o + 1], b.ram[o + 2], b.ram[o + 3]])
            };
            for (j, w) in want.iter().enumerate() {
                let got: Vec<u32> = (0..8).map(|f| word(8 * j + f)).collect();
                assert_eq!(
                    &got[..],
                    &w[..],
                    "disk {n}, image {i}, column {}",
                    c0 + j as i32
                );
            }
            shapes += 1;
        }
    }
    assert!(
        shapes > 700 && vertical > 200 && wrapping > 200,
        "{shapes} shapes, {vertical} with vertical segments, {wrapping} wrapping"
    );
}

/// The image's `__cspace_walk` (a pair's differences in the runtime's assembly) called
/// directly on the emulated CPU has the effect of the host's walk (`raster::walk_words`),
/// applied record by record to a map of counters at 3: for random columns with short runs
/// (a row or a few, where a breakpoint that moves passes its neighbour's other row and the
/// routine's run a breakpoint, for columns whose runs keep their counters, cuts the rows
/// otherwise than the host's walk), longer ones, full ones, the same counters or others,
/// moved by whole revolutions or not, over ranges of columns that overlap in part (columns
/// only one image has). The two record lists may differ (the routine also makes adjacent
/// runs with the same counters one); their effect may not.
#[test]
fn the_cspace_images_walk_has_the_hosts_effect() {
    use cspace::raster::{apply_record, walk_words};
    let (mut b, img, mut global) = system_tests::board_of(vme_map::BoardId::Cspace0);
    let routine = img.symbol("__cspace_walk").unwrap();
    // The old columns at OLD, the new at NEW (32 bytes each), the records at RECS.
    const OLD: u32 = 0xC0000;
    const NEW: u32 = 0xC1000;
    const RECS: u32 = 0xC2000;
    const CAP: u32 = 320;
    let mut rng = sim_host::sim::Rng::new(31);
    let pick = |rng: &mut sim_host::sim::Rng, n: u64| rng.next_u64() % n;
    // Each counter with probability 1/3.
    let random_mask = |rng: &mut sim_host::sim::Rng| {
        [0x0100_0000u32, 0x0001_0000, 0x0000_0100, 0x0000_0001]
            .iter()
            .fold(0, |m, &c| if pick(rng, 3) == 0 { m | c } else { m })
    };
    // Map column `c` of an image: its first row anywhere in +-300, a few rows (`short`) or
    // any number up to the whole column.
    let column = |rng: &mut sim_host::sim::Rng, c: i32, short: bool| {
        let rows = if short {
            1 + pick(rng, 6) as u32
        } else if pick(rng, 8) == 0 {
            128
        } else {
            pick(rng, 129) as u32
        };
        [
            (c as u32) & 127,
            (pick(rng, 600) as i32 - 300) as u32,
            rows,
            pick(rng, rows as u64 + 3) as u32,
            pick(rng, rows as u64 + 3) as u32,
            random_mask(rng),
            random_mask(rng),
            if pick(rng, 3) == 0 {
                random_mask(rng)
            } else {
                0
            },
        ]
    };
    let (mut runs, mut crossed) = (0, 0);
    for case in 0..3000 {
        let short = case % 4 != 3;
        let c0 = pick(&mut rng, 300) as i32 - 150;
        let n = 1 + pick(&mut rng, 4) as i32;
        let old: Vec<[u32; 8]> = (0..n).map(|j| column(&mut rng, c0 + j, short)).collect();
        // The new columns: over a range shifted by up to a column each way, each the old
        // one at that map column moved a little (breakpoints by 0-3 rows, now and then by
        // whole revolutions), its counters mostly kept, or a column of its own.
        let shift = pick(&mut rng, 3) as i32 - 1;
        let m = (n + pick(&mut rng, 3) as i32 - 1).max(1);
        let new: Vec<[u32; 8]> = (0..m)
            .map(|j| {
                let c = c0 + shift + j;
                let Some(o) = old.get((c - c0) as usize).filter(|_| c >= c0) else {
                    return column(&mut rng, c, short);
                };
                let mut k = *o;
                let nudge =
                    |rng: &mut sim_host::sim::Rng, v: u32| v as i32 + pick(rng, 7) as i32 - 3;
                let turns = 128 * (pick(&mut rng, 8) == 0) as i32;
                k[1] = (nudge(&mut rng, k[1]) + turns) as u32;
                k[2] = nudge(&mut rng, k[2]).clamp(0, 128) as u32;
                k[3] = nudge(&mut rng, k[3]).clamp(0, k[2] as i32 + 2) as u32;
                k[4] = nudge(&mut rng, k[4]).clamp(0, k[2] as i32 + 2) as u32;
                if pick(&mut rng, 4) == 0 {
                    k[5 + pick(&mut rng, 3) as usize] = random_mask(&mut rng);
                }
                k
            })
            .collect();
        let (oc, nc) = ((c0, c0 + n - 1), (c0 + shift, c0 + shift + m - 1));
        // The host's records, applied.
        let mut want = cspace::Memory::default();
        want.map.iter_mut().for_each(|w| *w = 0x0303_0303);
        let mut host_recs = Vec::new();
        let count = walk_words(&old, oc, &new, nc, |r| host_recs.push(r));
        assert!(count <= CAP as usize, "case {case}: {count} records");
        for r in &host_recs {
            apply_record(&mut want.canvas(), *r, &old, &new);
        }
        // The routine's.
        let put = |ram: &mut [u8], at: u32, cols: &[[u32; 8]]| {
            for (j, k) in cols.iter().enumerate() {
                for (f, w) in k.iter().enumerate() {
                    let o = at as usize + 32 * j + 4 * f;
                    ram[o..o + 4].copy_from_slice(&w.to_be_bytes());
                }
            }
        };
        put(&mut b.ram, OLD, &old);
        put(&mut b.ram, NEW, &new);
        let args = [
            OLD,
            oc.0 as u32,
            oc.1 as u32,
            NEW,
            nc.0 as u32,
            nc.1 as u32,
            RECS,
            CAP,
        ];
        let (got_n, _) = b
            .call(&mut global, routine, &args, 10_000_000)
            .expect("the routine returns");
        assert!(got_n <= CAP, "case {case}: {got_n} records");
        let word = |o: usize| {
            let o = RECS as usize + 4 * o;
            u32::from_be_bytes([b.ram[o], b.ram[o + 1], b.ram[o + 2], b.ram[o + 3]])
        };
        let mut got = cspace::Memory::default();
        got.map.iter_mut().for_each(|w| *w = 0x0303_0303);
        for i in 0..got_n as usize {
            let r = [
                word(5 * i),
                word(5 * i + 1),
                word(5 * i + 2),
                word(5 * i + 3),
                word(5 * i + 4),
            ];
            apply_record(&mut got.canvas(), r, &old, &new);
        }
        let differ = (0..128 * 128).find(|&i| got.map[i] != want.map[i]);
        assert!(
            differ.is_none(),
            "case {case}: pixel {:?}: {:08x} against the host's {:08x}\nold {old:?} {oc:?}\nnew {new:?} {nc:?}\nhost {host_recs:?}",
            differ.map(|i| (i % 128, i / 128)),
            differ.map_or(0, |i| got.map[i]),
            differ.map_or(0, |i| want.map[i]),
        );
        runs += host_recs.iter().filter(|r| r[0] & 0xFF == 0).count();
        // Columns where a breakpoint passed its neighbour's other row (counted on the
        // host's columns).
        for (j, k) in new.iter().enumerate() {
            let c = nc.0 + j as i32;
            if c < oc.0 || c > oc.1 {
                continue;
            }
            let o = &old[(c - oc.0) as usize];
            let bps = |w: &[u32; 8]| {
                let (f, r) = (w[1] as i32, w[2] as i32);
                let (mut l, mut u) = ((w[3] as i32).min(r), (w[4] as i32).min(r));
                if l > u {
                    std::mem::swap(&mut l, &mut u);
                }
                [f, f + l, f + u, f + r]
            };
            let (bo, bn) = (bps(o), bps(k));
            if (bn[0] - bo[0]).rem_euclid(128) > 8 && (bo[0] - bn[0]).rem_euclid(128) > 8 {
                continue;
            }
            if (0..3).any(|i| bo[i].max(bn[i]) > bo[i + 1].min(bn[i + 1])) {
                crossed += 1;
            }
        }
    }
    assert!(
        runs > 3000 && crossed > 300,
        "{runs} runs, {crossed} columns with a breakpoint past its neighbour"
    );
}

/// The image's `__cspace_same_shape` (which images' kept columns a move reuses) finds two
/// images the same only when every vertex of every chain and the wrap flag are: one word
/// changed anywhere, or the flag, parts them.
#[test]
fn the_cspace_images_shape_compare_sees_every_word() {
    let (mut b, img, mut global) = system_tests::board_of(vme_map::BoardId::Cspace0);
    let routine = img.symbol("__cspace_same_shape").unwrap();
    const A: u32 = 0xC0000;
    const B: u32 = 0xC1000;
    let shape = cspace::images(&random_disk(95, 1)).unwrap().front.unwrap();
    let bytes = |s: &cspace::Shape| {
        let mut v = Vec::new();
        for w in s.theta1_u.iter().chain(&s.upper_u).chain(&s.lower_u) {
            v.extend_from_slice(&w.to_be_bytes());
        }
        v.push(s.wraps as u8);
        v
    };
    let a = bytes(&shape);
    b.ram[A as usize..A as usize + a.len()].copy_from_slice(&a);
    let mut same = |b: &mut sim_host::emu::EmuBoard, other: &[u8]| {
        b.ram[B as usize..B as usize + other.len()].copy_from_slice(other);
        let (ret, _) = b
            .call(&mut global, routine, &[A, B], 1_000_000)
            .expect("the routine returns");
        ret
    };
    assert_eq!(same(&mut b, &a), 1, "an image and its copy");
    // Each of the 99 words changed in its lowest bit, then in its highest, then the flag.
    for word in 0..99 {
        for bit in [0, 31] {
            let mut other = a.clone();
            other[4 * word + 3 - bit / 8] ^= 1 << (bit % 8);
            assert_eq!(same(&mut b, &other), 0, "word {word} bit {bit} changed");
        }
    }
    let mut other = a.clone();
    other[396] ^= 1;
    assert_eq!(same(&mut b, &other), 0, "the wrap flag changed");
}

/// The cspace image's differential move (its column extents and pair walk in assembly,
/// through the probe `cspace_probe_move`) leaves the counters the host's draw-then-erase
/// leaves, bit for bit: for random disks moved a little (0-3 mm, the moves the boards redraw
/// most), further (0-40 mm) or anywhere, with new radii.
#[test]
fn the_cspace_image_moves_images_like_draw_then_erase() {
    let (mut b, img, mut global) = system_tests::board_of(vme_map::BoardId::Cspace0);
    let probe = img.symbol("cspace_probe_move").unwrap();
    let mut moved = 0;
    for n in 0..150 {
        let old = random_disk(91, n);
        let far = random_disk(92, n);
        let step = [3_000, 40_000, 0][n as usize % 3];
        let new = if step == 0 {
            far
        } else {
            // A move of up to `step` um each way (from the other random disk's digits).
            cspace::Disk {
                x_um: old.x_um + far.x_um % step,
                y_um: old.y_um + far.y_um % step,
                r_um: old.r_um + (far.r_um % 2_000).abs(),
            }
        };
        let (Ok(a), Ok(c)) = (cspace::images(&old), cspace::images(&new)) else {
            continue;
        };
        global.iter_mut().for_each(|x| *x = 0);
        let args = [old.x_um, old.y_um, old.r_um, new.x_um, new.y_um, new.r_um].map(|v| v as u32);
        let (ret, _) = b
            .call(&mut global, probe, &args, 200_000_000)
            .expect("probe returns");
        assert_eq!(ret, 0, "{old:?} -> {new:?}");
        let mut host = cspace::Memory::default();
        cspace::apply(&a, &mut host.canvas(), cspace::Op::Draw);
        let drawn = host.clone();
        cspace::apply(&c, &mut host.canvas(), cspace::Op::Draw);
        cspace::apply(&a, &mut host.canvas(), cspace::Op::Erase);
        assert_map_is(&global, &host, &format!("{old:?} -> {new:?}"));
        // Every column the draw wrote, and again every column the move changed, had its
        // generation raised after (the reflex reads again only columns whose generation
        // moved): at least once for each.
        let column = |m: &cspace::Memory, c: usize| {
            let mut w: Vec<u32> = (0..128).map(|r| m.map[r * 128 + c]).collect();
            w.push(m.stripes[c]);
            w
        };
        for c in 0..128 {
            let o = (vme_map::layout::cspace_gen(c as u32)) as usize;
            let gen = u32::from_be_bytes([global[o], global[o + 1], global[o + 2], global[o + 3]]);
            let wrote = column(&drawn, c).iter().any(|&w| w != 0) as u32;
            let changed = (column(&drawn, c) != column(&host, c)) as u32;
            assert!(
                gen >= wrote + changed,
                "{old:?} -> {new:?}: column {c} raised {gen} times, drawn {wrote}, changed {changed}"
            );
        }
        // And the map's epoch with every one of those raises (the reflex trusts a window it
        // proved free while the epoch stays).
        let word = |o: u32| {
            let o = o as usize;
            u32::from_be_bytes([global[o], global[o + 1], global[o + 2], global[o + 3]])
        };
        let raises: u32 = (0..128).map(|c| word(vme_map::layout::cspace_gen(c))).sum();
        assert_eq!(
            word(vme_map::layout::CSPACE_EPOCH),
            raises,
            "{old:?} -> {new:?}: the epoch against the generations' raises"
        );
        moved += 1;
    }
    assert!(moved > 100, "only {moved} moves had images");
}

/// Two moves on one board (`cspace_probe_move_twice`): the second takes the first's new
/// images' columns from those the board kept instead of computing them, and the map is
/// still, bit for bit, the host's image of the last disk.
#[test]
fn the_cspace_image_moves_again_from_the_columns_it_kept() {
    let (mut b, img, mut global) = system_tests::board_of(vme_map::BoardId::Cspace0);
    let probe = img.symbol("cspace_probe_move_twice").unwrap();
    let (mut moved, mut kept) = (0, 0);
    for n in 0..60 {
        let d0 = random_disk(96, n);
        let step = random_disk(97, n);
        let near = |d: cspace::Disk, k: i32| cspace::Disk {
            x_um: d.x_um + step.x_um % (3_000 * k),
            y_um: d.y_um + step.y_um % (3_000 * k),
            r_um: d.r_um,
        };
        let (d1, d2) = (near(d0, 1), near(near(d0, 1), 2));
        let (Ok(_), Ok(mid), Ok(last)) = (
            cspace::images(&d0),
            cspace::images(&d1),
            cspace::images(&d2),
        ) else {
            continue;
        };
        global.iter_mut().for_each(|x| *x = 0);
        let args = [d0, d1, d2].map(|d| [d.x_um, d.y_um, d.r_um]).concat();
        let args: Vec<u32> = args.iter().map(|&v| v as u32).collect();
        let (ret, _) = b
            .call(&mut global, probe, &args, 400_000_000)
            .expect("probe returns");
        assert!(ret as i32 >= 0, "{d0:?} -> {d1:?} -> {d2:?}");
        let mut host = cspace::Memory::default();
        cspace::apply(&last, &mut host.canvas(), cspace::Op::Draw);
        assert_map_is(&global, &host, &format!("{d0:?} -> {d1:?} -> {d2:?}"));
        // The second move's old images are the first's new ones: each kept and taken.
        let images = [mid.front, mid.rear].iter().filter(|s| s.is_some()).count();
        assert_eq!(ret as usize, images, "images of {d1:?} kept and taken");
        kept += ret;
        moved += 1;
    }
    assert!(
        moved > 40 && kept as usize >= moved,
        "{moved} moves, {kept} kept"
    );
}

/// The object table caught mid-publish is skipped, not a fault; a table left torn (a writer
/// that died mid-write) is recorded as TornRecord once it has stayed torn for
/// `TORN_PASSES` passes.
#[test]
fn a_torn_object_table_is_a_fault_only_when_it_stays_torn() {
    struct NoIo;
    impl regs::IoBus for NoIo {
        fn read16(&mut self, _off: u32) -> u16 {
            0
        }
        fn write16(&mut self, _off: u32, _val: u16) {}
    }
    let mut global = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
    let mut g = vme_map::ArrayBus::new(&mut global);
    vme_map::init_header(&mut g);
    let mut board = board_cspace::Board::new(
        vme_map::BoardId::Cspace0,
        Box::new(cspace::worklist::Scratch::new()),
    );
    board.boot(&mut g, &mut NoIo);
    vme_map::OBJECTS.publish_torn(&mut g, &vme_map::records::ObjectTable::default());
    let slot = vme_map::BoardSlot::of(vme_map::BoardId::Cspace0);
    for pass in 1..board_cspace::TORN_PASSES {
        board.poll(&mut g, &mut NoIo);
        let st = slot.status_word(&mut g);
        assert_eq!(
            st.state(),
            Some(vme_map::BoardState::Running),
            "pass {pass}"
        );
        assert_eq!(st.faults(), 0, "pass {pass}");
    }
    board.poll(&mut g, &mut NoIo);
    let st = slot.status_word(&mut g);
    assert_eq!(st.state(), Some(vme_map::BoardState::Degraded));
    assert_eq!(st.fault(), Some(vme_map::FaultCode::TornRecord));
    // A whole table again: running.
    vme_map::OBJECTS.publish(&mut g, &vme_map::records::ObjectTable::default());
    board.poll(&mut g, &mut NoIo);
    assert_eq!(
        slot.status_word(&mut g).state(),
        Some(vme_map::BoardState::Running)
    );
}

/// `cspace::worklist::REACH_UM`, where a fold beyond the calibrated square ends, is the
/// outline's reach from the shoulder (the tip's disk), not less.
#[test]
fn the_fold_reach_is_the_outlines() {
    // The reach is the outline's: the tip's disk, the farthest part from the shoulder.
    let reach_m = arm::geometry::OUTLINE
        .iter()
        .map(|(body, part)| match (body, part) {
            (arm::geometry::Body::Link2, arm::geometry::Part::Disk { s_m, r_m }) => {
                arm::geometry::L1_M + s_m.abs() + r_m
            }
            (
                _,
                arm::geometry::Part::Rect {
                    s0_m,
                    s1_m,
                    half_width_m,
                },
            ) => {
                let s = s0_m.abs().max(s1_m.abs());
                let along = if matches!(body, arm::geometry::Body::Link2) {
                    arm::geometry::L1_M + s
                } else {
                    s
                };
                along.hypot(*half_width_m)
            }
            (_, arm::geometry::Part::Disk { s_m, r_m }) => s_m.abs() + r_m,
        })
        .fold(0.0, f64::max);
    assert!(
        cspace::worklist::REACH_UM as f64 >= reach_m * 1e6 - 0.5,
        "{reach_m}"
    );
    assert!(
        (cspace::worklist::REACH_UM as f64) < reach_m * 1e6 + 1_000.0,
        "{reach_m}"
    );
}
