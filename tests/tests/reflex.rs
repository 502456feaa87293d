//! The reflex board (issue 8): its image against the host bit for bit over scripted passes
//! that reach every regime (free growth, walls, braking, escape, stall, holds for each input
//! fault, planner and wand goals).

use reflex::script::{scripted_pass, IN_WORDS, OUT_WORDS};
use reflex::Reflex;
use sim_host::emu::EmuBoard;
use sim_host::image::Image;
use sim_host::sim::Rng;
use system_tests::{images_dir, put_word, ram_word};
use vme_map::{ArrayBus, BoardId, GLOBAL_RAM_SIZE};

/// Scratch RAM for the probe's script: above the image's code, below its data and bss at
/// 0x80000 (linker/board.ld), room for 2,340 passes.
const BUF: u32 = 0x0002_0000;
/// Scratch RAM for the probe's results: above the data and bss, far below the stack.
const OUT: u32 = 0x0009_0000;

/// The reflex image on a standalone board over `global`, its probe `name`'s address, and
/// `words` written to its RAM at [`BUF`].
fn probe_board(img: &Image, global: &mut [u8], name: &str, words: &[u32]) -> (EmuBoard, u32) {
    let mut b = EmuBoard::new(
        BoardId::Reflex,
        img,
        sim_host::devices::standalone(BoardId::Reflex),
        global,
    );
    let f = img
        .symbol(name)
        .unwrap_or_else(|| panic!("{name} in the image"));
    for (k, &w) in words.iter().enumerate() {
        put_word(&mut b.ram, BUF + 4 * k as u32, w);
    }
    (b, f)
}

/// The host's answers to `asks`, `I` words a question: `f` answers each into `O` words (the
/// probes' scripted functions, run on the host).
fn host_each<T: Copy, const I: usize, const O: usize>(
    asks: &[T],
    mut f: impl FnMut(&[T; I], &mut [i32; O]),
) -> Vec<[i32; O]> {
    asks.chunks(I)
        .map(|w| {
            let mut o = [0; O];
            f(w.try_into().unwrap(), &mut o);
            o
        })
        .collect()
}

/// Probe `name` on the reflex image, called once per question of `asks` (`in_words` words
/// each, answered at [`OUT`]): asserts each answer is the host's (`host[i]`, `what` naming
/// a question in the message) and returns each call's cycles.
fn probe_each<H: AsRef<[i32]>>(
    img: &Image,
    global: &mut [u8],
    name: &str,
    asks: &[i32],
    in_words: usize,
    host: &[H],
    what: &str,
) -> Vec<u64> {
    let out_words = host[0].as_ref().len();
    let words: Vec<u32> = asks.iter().map(|&w| w as u32).collect();
    let (mut b, f) = probe_board(img, global, name, &words);
    let mut cycles = Vec::new();
    for i in 0..host.len() as u32 {
        let (ret, c) = b
            .call(
                global,
                f,
                &[
                    BUF + 4 * in_words as u32 * i,
                    1,
                    OUT + 4 * out_words as u32 * i,
                ],
                100_000_000,
            )
            .unwrap_or_else(|| panic!("the probe returns: {:?} at pc {:#x}", b.state, b.cpu.pc));
        assert_eq!(ret, 0);
        cycles.push(c);
    }
    for (i, h) in host.iter().enumerate() {
        let got = ram_words(&b, OUT + 4 * (out_words * i) as u32, out_words);
        assert_eq!(
            got,
            h.as_ref().to_vec(),
            "{what} {i}: {:?}",
            &asks[i * in_words..][..in_words]
        );
    }
    cycles
}

/// `n` words of the board's RAM from `addr`.
fn ram_words(b: &EmuBoard, addr: u32, n: usize) -> Vec<i32> {
    (0..n as u32)
        .map(|k| ram_word(&b.ram, addr + 4 * k) as i32)
        .collect()
}

/// Global RAM with a C-space map of `disks` (x mm, y mm, r mm) drawn by the C-space logic.
fn global_with(disks: &[(i32, i32, i32)]) -> Vec<u8> {
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    vme_map::init_header(&mut ArrayBus::new(&mut global));
    sim_host::cspace_oracle::draw_disks_mm(&mut ArrayBus::new(&mut global), disks).unwrap();
    global
}

/// A script of `n` passes: the host reflex drives a simple arm (speed toward its subgoal
/// limited, the arrest point from its speed) among the map's obstacles, with goals from the
/// planner and the wand, an obstacle moved onto the arm, torn and stale inputs in phases.
fn script(global: &mut [u8], n: usize) -> Vec<u32> {
    let mut r = Reflex::default();
    let mut rng = Rng::new(8);
    let mut th = [0.3f64, -0.4];
    let mut w = [0.0f64; 2];
    let mut sub = th;
    let mut out = Vec::new();
    let brake = [220.0, 700.0];
    // A pixel deep inside an obstacle (all its neighbours marked): a goal there stalls the
    // arm at the wall, and the arm put there must escape.
    let inside = {
        let mut g = ArrayBus::new(global);
        let marked = |g: &mut ArrayBus, i1: i32, i2: i32| {
            use vme_map::GlobalBus;
            g.read_u32(vme_map::layout::cspace_counter(
                (i1 & 127) as u32,
                (i2 & 127) as u32,
                0,
            )) != 0
        };
        let mut found = None;
        'search: for i2 in 0..128 {
            for i1 in 0..128 {
                if (-2..=2).all(|a| (-2..=2).all(|b| marked(&mut g, i1 + a, i2 + b))) {
                    found = Some([i1, i2]);
                    break 'search;
                }
            }
        }
        let p = found.expect("an obstacle with an interior");
        let px = std::f64::consts::TAU / 128.0;
        [(p[0] as f64 + 0.5) * px, (p[1] as f64 + 0.5) * px]
    };
    for k in 0..n {
        // Into the obstacle at the start of phase 6 and every 40 passes of it.
        if k == n * 6 / 10 || (k * 10 / n == 6 && k % 40 == 0) {
            th = inside;
            w = [0.0; 2];
        }
        let t_us = 1000 * k as u32 + (rng.next_u64() % 300) as u32;
        for i in 0..2 {
            let e = sub[i] - th[i];
            if e.abs() < 1e-4 && w[i].abs() < 0.2 {
                w[i] = 0.0;
                continue;
            }
            let want = e.signum() * (2.0 * brake[i] * e.abs()).sqrt().min(25.0);
            let dv = (want - w[i]).clamp(-brake[i] * 1e-3, brake[i] * 1e-3);
            w[i] += dv;
            th[i] += w[i] * 1e-3;
        }
        let arrest = |i: usize| th[i] + w[i] * w[i].abs() / (2.0 * brake[i] / 1.2);
        let phase = k * 10 / n;
        let mut words = [0u32; IN_WORDS];
        words[0] = (phase != 7 || k % 60 < 30) as u32;
        let urad = |a: f64| (a * 1e6).round() as i32 as u32;
        words[1] = urad(th[0]);
        words[2] = urad(th[1]);
        words[3] = urad(w[0]);
        words[4] = urad(w[1]);
        words[5] = urad(arrest(0));
        words[6] = urad(arrest(1));
        words[7] = t_us;
        words[8] = if phase == 8 && k % 230 > 115 {
            4242
        } else {
            3 * k as u32
        };
        match phase {
            0..=3 => {
                let g = [inside, inside, [2.8, -0.5], [0.2, 0.2]][phase];
                words[9] = 1;
                words[10] = urad(g[0]);
                words[11] = urad(g[1]);
                words[12] = if phase == 3 && k % 200 > 120 {
                    7
                } else {
                    k as u32
                };
            }
            4 | 5 => {
                words[9] = 2;
                words[10] = (300_000 - 1000 * (k % 200) as i32) as u32;
                words[11] = (150_000 + 700 * (k % 150) as i32) as u32;
            }
            _ => words[9] = 0,
        }
        let frozen = phase == 6 && k % 200 > 120;
        words[13] = if frozen { 17 } else { k as u32 };
        words[16] = if phase == 9 && k % 200 > 100 {
            5
        } else {
            k as u32 / 2
        };
        // Obstacles flagged moving while the arm sits inside one (every other 40 passes of
        // phase 6): the escape may cross marked pixels.
        let moving = phase == 6 && (k / 40) % 2 == 0;
        words[17] = (k % 97 == 0) as u32 | (moving as u32) << 1;
        for e in 0..6 {
            let b = 18 + 4 * e;
            words[b] = if phase == 5 && e == 2 && k % 100 > 60 {
                2
            } else {
                0
            };
            words[b + 1] = (k / 40) as u32;
            words[b + 2] = 1;
            words[b + 3] = if phase == 8 && e == 4 && k % 230 <= 115 {
                30_000
            } else {
                200
            };
        }
        out.extend_from_slice(&words);
        let mut o = [0i32; OUT_WORDS];
        scripted_pass(
            &mut r,
            &words,
            &mut reflex::window::BusMap(&mut ArrayBus::new(global)),
            &mut o,
        );
        if o[0] != 0 {
            sub = [o[1] as f64 * 1e-6, o[2] as f64 * 1e-6];
        }
    }
    out
}

fn host_run(global: &mut [u8], inputs: &[u32]) -> Vec<[i32; OUT_WORDS]> {
    let mut r = Reflex::default();
    host_each::<u32, IN_WORDS, OUT_WORDS>(inputs, |w, o| {
        scripted_pass(
            &mut r,
            w,
            &mut reflex::window::BusMap(&mut ArrayBus::new(global)),
            o,
        )
    })
}

#[test]
fn the_reflex_image_steps_like_the_host() {
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = global_with(&[(300, 300, 30), (-200, 350, 25), (100, -380, 40)]);
    let n = 2300;
    assert!(BUF as usize + 4 * IN_WORDS * n <= 0x8_0000);
    let inputs = script(&mut global, n);
    let host = host_run(&mut global, &inputs);
    let (mut b, f) = probe_board(&img, &mut global, "reflex_probe_run", &inputs);
    let out = OUT;
    let (ret, cycles) = b
        .call(&mut global, f, &[BUF, n as u32, out], 4_000_000_000)
        .unwrap_or_else(|| panic!("the probe returns: {:?} at pc {:#x}", b.state, b.cpu.pc));
    assert_eq!(ret, 0);
    let mut seen = std::collections::BTreeMap::new();
    for (i, h) in host.iter().enumerate() {
        let got = ram_words(&b, out + 4 * (OUT_WORDS * i) as u32, OUT_WORDS);
        assert_eq!(got, h.to_vec(), "pass {i}");
        for bit in 0..11 {
            if h[3] & (1 << bit) != 0 {
                *seen.entry(format!("flag{bit}")).or_insert(0) += 1;
            }
        }
        if h[12] != 0 {
            *seen.entry(format!("fault{}", h[12])).or_insert(0) += 1;
        }
    }
    eprintln!("{n} passes in {cycles} cycles; seen {seen:?}");
    use vme_map::records::reflex_flags as rf;
    for (what, bit) in [
        ("blocked", rf::BLOCKED1 | rf::BLOCKED2),
        ("braking", rf::BRAKING),
        ("hold", rf::HOLD),
        ("planner", rf::FROM_PLANNER),
        ("wand", rf::FROM_WAND),
        ("at goal", rf::AT_GOAL),
        ("escaping", rf::ESCAPING),
        ("stalled", rf::STALLED),
    ] {
        assert!(
            host.iter().any(|h| h[3] as u32 & bit != 0),
            "the script never reached {what}"
        );
    }
    for code in [1, 2, 3, 4, 5, 6, 7] {
        assert!(
            host.iter().any(|h| h[12] == code),
            "the script never raised fault {code}"
        );
    }
}

/// The escape planner (`reflex::escape`) on the image against the host, plan for plan, on a
/// map of overlapping disks: arms inside obstacles, on their borders, in the open and near
/// the torus edges; with and without crossing marks, each clearance, with and without a
/// previous target. Prints the image's cycles per plan.
#[test]
fn the_reflex_images_escapes_match_the_host() {
    use reflex::script::{scripted_escape, ESCAPE_IN_WORDS, ESCAPE_OUT_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = global_with(&[
        (300, 300, 30),
        (-200, 350, 25),
        (100, -380, 40),
        (330, 250, 20),
        (-420, -60, 35),
    ]);
    let marked = |g: &mut [u8], i1: i32, i2: i32| {
        use vme_map::GlobalBus;
        ArrayBus::new(g).read_u32(vme_map::layout::cspace_counter(
            (i1 & 127) as u32,
            (i2 & 127) as u32,
            0,
        )) != 0
    };
    let mut rng = Rng::new(11);
    let n = 600;
    let mut asks = Vec::new();
    let (mut inside, mut border) = (0, 0);
    while asks.len() < n * ESCAPE_IN_WORDS {
        let at = [
            (rng.next_u64() % 128) as i32 - 64,
            (rng.next_u64() % 128) as i32,
        ];
        let here = marked(&mut global, at[0], at[1]);
        let near = (-3..=3).any(|a| (-3..=3).any(|b| marked(&mut global, at[0] + a, at[1] + b)));
        // Mostly arms with marks around (the escape's business), a few in the open.
        if !near && !rng.next_u64().is_multiple_of(8) {
            continue;
        }
        inside += here as u32;
        border += (near && !here) as u32;
        let mut r = |m: u64| (rng.next_u64() % m) as i32;
        let toward = [at[0] + r(41) - 20, at[1] + r(41) - 20];
        let prev = [at[0] + r(9) - 4, at[1] + r(9) - 4];
        asks.extend_from_slice(&[
            at[0],
            at[1],
            toward[0],
            toward[1],
            r(5),
            r(2),
            r(2),
            prev[0],
            prev[1],
        ]);
    }
    assert!(
        inside > 100 && border > 100,
        "{inside} inside, {border} on borders"
    );
    let mut s = reflex::escape::Scratch::new();
    let host = host_each::<i32, ESCAPE_IN_WORDS, ESCAPE_OUT_WORDS>(&asks, |w, o| {
        scripted_escape(
            &mut s,
            w,
            &mut reflex::window::BusMap(&mut ArrayBus::new(&mut global)),
            o,
        )
    });
    let crossed = host.iter().filter(|o| o[0] == 1 && o[6] > 0).count();
    let none = host.iter().filter(|o| o[0] == 0).count();
    assert!(crossed > 20, "only {crossed} plans crossed marks");
    // A call a plan, for each plan's cycles (the scratch bitmaps carry nothing over).
    let cycles = probe_each(
        &img,
        &mut global,
        "reflex_probe_escape",
        &asks,
        ESCAPE_IN_WORDS,
        &host,
        "plan",
    );
    let mean = cycles.iter().sum::<u64>() / n as u64;
    let (worst, wi) = cycles
        .iter()
        .enumerate()
        .map(|(i, &c)| (c, i))
        .max()
        .unwrap();
    eprintln!(
        "{n} escape plans ({inside} inside, {border} on borders, {crossed} crossed marks, \
         {none} none): {mean} cycles a plan on average, {worst} at most (plan {wi}: {:?} -> {:?})",
        &asks[wi * ESCAPE_IN_WORDS..][..ESCAPE_IN_WORDS],
        host[wi]
    );
}

/// The evasion (`reflex::evade`) on the image against the host, answer for answer: arms
/// anywhere with one to six disks of 10-50 mm within 150 mm of a point of link 2, resting or
/// moving at up to 0.4 m/s,
/// some slots empty; each of the 49 ways' score (samples to contact and to the margin) and
/// the one chosen. Also checks that the answers are not all alike (some ways last the
/// horizon, some touch at once, the chosen way varies, at every speed). Prints the image's
/// cycles per answer.
#[test]
fn the_reflex_images_evasions_match_the_host() {
    use reflex::script::{scripted_evade, EVADE_IN_WORDS, EVADE_OUT_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let mut rng = Rng::new(21);
    let n = 300;
    let mut asks: Vec<i32> = Vec::new();
    for _ in 0..n {
        let mut r = |m: u64| (rng.next_u64() % m) as i32;
        let th = [r(12_566_371) - 6_283_185, r(12_566_371) - 6_283_185];
        let (t1, t2) = (th[0] as f64 * 1e-6, th[1] as f64 * 1e-6);
        // Near a point of the arm: the elbow or along link 2 (fore or aft).
        let s = (r(380) - 130) as f64 * 1e-3;
        let (px, py) = (
            0.25 * t1.cos() + s * t2.cos(),
            0.25 * t1.sin() + s * t2.sin(),
        );
        let way = |k: i32| reflex::evade::WAY_MULT[k as usize];
        asks.extend_from_slice(&[th[0], th[1], way(r(7)), way(r(7)), 1]);
        let disks = 1 + r(6);
        for i in 0..reflex::OBSTACLES as i32 {
            let off = |v: i32| (v - 150) as f64 * 1e-3;
            let (x, y) = (px + off(r(301)), py + off(r(301)));
            asks.extend_from_slice(&[
                (i < disks) as i32,
                (x * 1e6) as i32,
                (y * 1e6) as i32,
                10_000 + r(40_001),
                r(800_001) - 400_000,
                r(800_001) - 400_000,
            ]);
        }
    }
    let mut sc = reflex::evade::Scratch::new();
    let mut obs = [reflex::ObstacleView::NONE; reflex::OBSTACLES];
    // The host's answers, and the image's cycles for the same (checked against them).
    let mut answer = |asks: &[i32], what: &str| {
        let host = host_each::<i32, EVADE_IN_WORDS, EVADE_OUT_WORDS>(asks, |w, o| {
            scripted_evade(&mut sc, w, &mut obs, o)
        });
        let cycles = probe_each(
            &img,
            &mut global,
            "reflex_probe_evade",
            asks,
            EVADE_IN_WORDS,
            &host,
            what,
        );
        (host, cycles)
    };
    let (host, _) = answer(&asks, "evasion");
    let horizon = reflex::evade::STEPS as i32 - 1;
    // Scores: samples to contact times 32 plus samples to the margin.
    let at_once = host
        .iter()
        .filter(|o| o[3..].iter().any(|&s| s >> 5 == 0))
        .count();
    let through = host
        .iter()
        .filter(|o| o[3..].contains(&(horizon * 33)))
        .count();
    let moved = host.iter().filter(|o| o[0] != 0 || o[1] != 0).count();
    let speeds: std::collections::BTreeSet<i32> =
        host.iter().flat_map(|o| [o[0].abs(), o[1].abs()]).collect();
    assert!(
        at_once > 30 && through > 30 && moved > 30 && speeds.len() == 4,
        "{at_once} with a way touching at once, {through} with one lasting, {moved} moving, \
         speeds chosen {speeds:?}"
    );
    // Again with the best way alone, as the reflex asks: its cycles.
    for a in asks.chunks_mut(EVADE_IN_WORDS) {
        a[4] = 0;
    }
    let (_, cycles) = answer(&asks, "evasion (best way)");
    let mean = cycles.iter().sum::<u64>() / n as u64;
    let worst = cycles.iter().max().unwrap();
    eprintln!(
        "{n} evasions ({at_once} with a way touching at once, {through} with one lasting, \
         {moved} moving, speeds chosen {speeds:?}): {mean} cycles an answer on average, \
         {worst} at most"
    );
}

/// The safety campaign (issue 8): zero collisions in 2,000 random static scenes with the
/// sensing, C-space, servo and reflex boards, the collision oracle at every plant step
/// (`sim-host campaign reflex` runs any seed and count), with the disks where the camera
/// sees them (the default) and again anywhere the arm reaches.
/// The image's `__reflex_gens_moved` (whether the escape's kept plan still stands, and
/// which window columns to read again): 0 when the window's 32 generation words, from any
/// first column and wrapping past 127, are the saved ones, else bit k for each word k that
/// is not, with all 32 saved anew; one or several words changed anywhere in the window (in
/// either run of a wrapping one) or none, as the escape's Rust answers.
#[test]
fn the_reflex_images_window_generations_match_the_host() {
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let (mut b, f) = probe_board(&img, &mut global, "__reflex_gens_moved", &[]);
    const GENS: u32 = BUF;
    const SAVED: u32 = BUF + 0x400;
    const N: usize = reflex::escape::WIN;
    let mut rng = Rng::new(23);
    let (mut moved, mut still) = (0, 0);
    for n in 0..400 {
        let gens: Vec<u32> = (0..128).map(|_| (rng.next_f64() * 50.0) as u32).collect();
        let c0 = (rng.next_f64() * 128.0) as usize;
        let window: Vec<u32> = (0..N).map(|k| gens[(c0 + k) % 128]).collect();
        let mut saved = window.clone();
        match n % 4 {
            0 => {}
            // One word of the window changed, anywhere in it.
            1 => saved[(rng.next_f64() * N as f64) as usize] ^= 1 << (n % 31),
            // Several (the first and the last among them now and then).
            2 => {
                for _ in 0..1 + n % 7 {
                    saved[(rng.next_f64() * N as f64) as usize] ^= 1 << (n % 29);
                }
                if n % 3 == 0 {
                    saved[0] ^= 1;
                    saved[N - 1] ^= 2;
                }
            }
            // A word just outside it changed: the window is still the same.
            _ => {
                let out = (c0 + N + (rng.next_f64() * (128 - N) as f64) as usize) % 128;
                let mut g = gens.clone();
                g[out] ^= 7;
                for (k, &w) in g.iter().enumerate() {
                    put_word(&mut b.ram, GENS + 4 * k as u32, w);
                }
            }
        }
        if n % 4 != 3 {
            for (k, &w) in gens.iter().enumerate() {
                put_word(&mut b.ram, GENS + 4 * k as u32, w);
            }
        }
        for (k, &w) in saved.iter().enumerate() {
            put_word(&mut b.ram, SAVED + 4 * k as u32, w);
        }
        let args = [GENS, c0 as u32, SAVED, N as u32];
        let (ret, _) = b.call(&mut global, f, &args, 100_000).expect("returns");
        let changed = saved != window;
        let mask = (0..N).fold(0u32, |m, k| m | ((saved[k] != window[k]) as u32) << k);
        assert_eq!(ret, mask, "ask {n}: first column {c0}");
        let after: Vec<u32> = (0..N)
            .map(|k| ram_word(&b.ram, SAVED + 4 * k as u32))
            .collect();
        assert_eq!(after, window, "ask {n}: the saved words");
        moved += changed as u32;
        still += !changed as u32;
    }
    assert!(moved > 150 && still > 150, "{moved} moved, {still} not");
}

/// The image's `__reflex_put_column` (a column of the escape's window read again): each
/// row's bit set or cleared by the column's marks as the escape's Rust does it, the other
/// bits left, and the answer the bit when a row's bit changed; any column, marks none,
/// some, all, and the rows' bits already as marked.
#[test]
fn the_reflex_images_column_puts_match_the_host() {
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let (mut b, f) = probe_board(&img, &mut global, "__reflex_put_column", &[]);
    const N: usize = reflex::escape::WIN;
    let mut rng = Rng::new(29);
    let word = |rng: &mut Rng| (rng.next_f64() * 4_294_967_296.0) as u32;
    let (mut changed, mut same) = (0, 0);
    for n in 0..400 {
        let mut rows = [0u32; N];
        for r in rows.iter_mut() {
            *r = word(&mut rng);
        }
        let k = n % 32;
        let bit = 1u32 << k;
        let marked = match n % 5 {
            0 => 0,
            1 => u32::MAX,
            // The rows already as marked: nothing changes.
            2 => (0..N).fold(0, |m, r| m | (((rows[r] & bit) == 0) as u32) << r),
            _ => word(&mut rng),
        };
        for (r, &w) in rows.iter().enumerate() {
            put_word(&mut b.ram, BUF + 4 * r as u32, w);
        }
        let (ret, _) = b
            .call(&mut global, f, &[BUF, marked, bit], 100_000)
            .expect("returns");
        let mut want = rows;
        let want_ret = reflex::escape::put_column(&mut want, marked, bit);
        let got: Vec<u32> = (0..N)
            .map(|r| ram_word(&b.ram, BUF + 4 * r as u32))
            .collect();
        assert_eq!(got, want.to_vec(), "ask {n}: column {k}, marks {marked:#x}");
        assert_eq!(ret, want_ret, "ask {n}: column {k}, marks {marked:#x}");
        changed += (want_ret != 0) as u32;
        same += (want_ret == 0) as u32;
    }
    assert!(changed > 150 && same > 50, "{changed} changed, {same} not");
}

#[test]
fn no_collision_in_2000_random_static_scenes() {
    use sim_host::campaign::{campaign, Kind, Place};
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    for place in [Place::Sensed, Place::Reach] {
        let (s, _) = campaign(Kind::Static, place, 1, 2000, threads, &|| {});
        assert_eq!(
            s.scenes_with_collisions,
            0,
            "collisions in scenes {:?} (replay: sim-host campaign reflex --seed 1 --place {})",
            s.collision_scenes,
            place.name()
        );
        assert!(s.min_clearance_m > 0.0, "{place:?}");
        // The campaign means something: many goals are reached, some are blocked.
        assert!(s.goals_reached > 800, "{s:?}");
        assert!(s.stalled > 0, "{s:?}");
    }
}

/// Runs a shipped scenario; returns the flags the reflex published at each millisecond, the
/// final angles, the goal pose the reflex used and the collision count.
fn run_figure(file: &str) -> (Vec<u32>, [f64; 2], [f64; 2], u64) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sim-host/scenarios")
        .join(file);
    let sc = sim_host::scenario::Scenario::load(&path).unwrap();
    let mut sim = sim_host::sim::Sim::new(sc.config);
    let mut flags = Vec::new();
    while !sim.done() {
        sim.step();
        if sim.steps.is_multiple_of(20) {
            flags.push(
                vme_map::REFLEX_SUBGOAL
                    .read(&mut sim.bus())
                    .map_or(0, |r| r.0.flags),
            );
        }
    }
    let st = vme_map::REFLEX_STATUS.read(&mut sim.bus()).unwrap().0;
    let goal = [st.goal1_urad as f64 * 1e-6, st.goal2_urad as f64 * 1e-6];
    (flags, sim.plant.angles_rad(), goal, sim.collisions.events)
}

/// Figs. V.6-V.10 as scenarios: each shows the behaviour the thesis's figure shows.
#[test]
fn the_figures_of_chapter_v_behave_as_in_the_thesis() {
    use vme_map::records::reflex_flags as rf;
    let px = std::f64::consts::TAU / 128.0;
    let near = |a: [f64; 2], b: [f64; 2], i: usize| (a[i] - b[i]).abs() < 0.01;
    // V.6 and V.7: the goal reached; V.6's goal is inside the first window.
    for f in ["fig_v_6.toml", "fig_v_7.toml"] {
        let (flags, end, goal, hits) = run_figure(f);
        assert_eq!(hits, 0, "{f}");
        assert!(
            near(end, goal, 0) && near(end, goal, 1),
            "{f}: {end:?} vs {goal:?}"
        );
        // The first pass with the wand's goal.
        let first = flags.iter().position(|&x| x & rf::FROM_WAND != 0).unwrap();
        let at_goal_first = flags[first] & rf::AT_GOAL != 0;
        assert_eq!(
            at_goal_first,
            f == "fig_v_6.toml",
            "{f}: first subgoal flags {:#x}",
            flags[first]
        );
    }
    // V.8: theta1 stopped at the wall, theta2 at its goal.
    let (flags, end, goal, hits) = run_figure("fig_v_8.toml");
    assert_eq!(hits, 0);
    let last = *flags.last().unwrap();
    assert_ne!(last & rf::BLOCKED1, 0, "{last:#x}");
    assert!(near(end, goal, 1), "theta2 {end:?} vs {goal:?}");
    assert!(
        (end[0] - goal[0]).abs() > 5.0 * px,
        "theta1 {end:?} vs {goal:?}"
    );
    // V.9: both axes stopped, the stall flagged.
    let (flags, end, goal, hits) = run_figure("fig_v_9.toml");
    assert_eq!(hits, 0);
    let last = *flags.last().unwrap();
    assert_eq!(
        last & (rf::BLOCKED1 | rf::BLOCKED2 | rf::STALLED),
        rf::BLOCKED1 | rf::BLOCKED2 | rf::STALLED,
        "{last:#x}"
    );
    assert!(!near(end, goal, 0) && !near(end, goal, 1));
    // V.10: out of the marked region first, then to the goal, never touching the obstacle.
    let (flags, end, goal, hits) = run_figure("fig_v_10.toml");
    assert_eq!(hits, 0);
    assert!(flags.iter().any(|&x| x & rf::ESCAPING != 0));
    assert!(
        near(end, goal, 0) && near(end, goal, 1),
        "{end:?} vs {goal:?}"
    );
}

/// The servo board rides out a subgoal record caught mid-publish for a few passes (the
/// emulator can stop a writer mid-publish for a whole time slice), and records one left torn
/// (a reflex that died mid-write) as a fault and holds.
#[test]
fn the_servo_rides_out_a_torn_subgoal_briefly_and_faults_on_one_left_torn() {
    use sim_host::sim::{Config, Sim};
    use vme_map::records::ReflexSubgoal;
    let cfg = Config {
        duration_s: 1.0,
        boards: vec![(BoardId::Servo, 1.0 / 3000.0)],
        ..Config::default()
    };
    let mut sim = Sim::new(cfg);
    let mut cycle = 0;
    sim_host::sensing_cal::hold_at(&mut sim, [0.2, 0.1], 0.1, &mut cycle);
    let status = |sim: &mut Sim| vme_map::BoardSlot::of(BoardId::Servo).status_word(&mut sim.bus());
    let rec = ReflexSubgoal {
        goal1_urad: 200_000,
        goal2_urad: 100_000,
        flags: 0,
        cycle: cycle + 1,
    };
    // Torn for 1 ms (three servo passes): no fault.
    vme_map::REFLEX_SUBGOAL.publish_torn(&mut sim.bus(), &rec);
    for _ in 0..20 {
        sim.step();
    }
    vme_map::REFLEX_SUBGOAL.publish(&mut sim.bus(), &rec);
    for _ in 0..20 {
        sim.step();
    }
    assert_eq!(status(&mut sim).fault(), Some(vme_map::FaultCode::None));
    // Left torn: a fault within TORN_PASSES passes.
    vme_map::REFLEX_SUBGOAL.publish_torn(&mut sim.bus(), &rec);
    for _ in 0..(20 * board_servo::TORN_PASSES as usize) {
        sim.step();
    }
    let st = status(&mut sim);
    assert_eq!(st.fault(), Some(vme_map::FaultCode::TornRecord));
    assert_eq!(st.state(), Some(vme_map::BoardState::Degraded));
}

/// The reflex's known columns (`reflex::window::Known`, the runtime's `__reflex_known_hits`
/// on the image) against the host, step for step: rectangles and columns asked again and
/// again around a moving place, pixels and stripe words written between (each followed by
/// its column's raise), across the torus's edges. Every answer, words read and pixels
/// vouched for included, must be the host's; most must be vouched for without a read; and
/// every free or not-free answer must be what reading the map afresh says (a fresh `Known`
/// each step), so neither the runs kept nor the marked rows kept outlive a write.
#[test]
fn the_reflex_images_known_columns_match_the_host() {
    use reflex::script::{scripted_known, KNOWN_IN_WORDS, KNOWN_OUT_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = global_with(&[(300, 300, 30), (-200, 350, 25), (100, -380, 40)]);
    let mut rng = Rng::new(5);
    let mut asks = Vec::new();
    let (mut at1, mut at2) = (120i32, 60i32);
    for _ in 0..1500 {
        let mut r = |m: u64| (rng.next_u64() % m) as i32;
        match r(12) {
            // A write near the place asked about: set or (twice as often) cleared, now and
            // then a stripe.
            0 => {
                let stripe = (r(8) == 0) as i32;
                let set = (r(3) == 0) as i32;
                asks.extend_from_slice(&[0, at1 + r(30) - 5, at2 + r(50) - 5, stripe, set]);
            }
            // The place drifts as an arm's would.
            2 => {
                at1 += r(5) - 2;
                at2 += r(5) - 2;
            }
            3 => asks.extend_from_slice(&[2, at1 + r(24) - 2, 0, at2 + r(8) - 4, 1 + r(40)]),
            _ => {
                let tall = r(20) == 0;
                asks.extend_from_slice(&[
                    1,
                    at1 + r(3) - 1,
                    1 + r(20),
                    at2 + r(3) - 1,
                    1 + r(if tall { 130 } else { 40 }),
                ])
            }
        }
    }
    let mut host_global = global.clone();
    let mut k = reflex::window::Known::new();
    let host = host_each::<i32, KNOWN_IN_WORDS, KNOWN_OUT_WORDS>(&asks, |w, o| {
        scripted_known(&mut k, &mut ArrayBus::new(&mut host_global), w, o)
    });
    let mut fresh_global = global.clone();
    let fresh = host_each::<i32, KNOWN_IN_WORDS, KNOWN_OUT_WORDS>(&asks, |w, o| {
        let mut k = reflex::window::Known::new();
        scripted_known(&mut k, &mut ArrayBus::new(&mut fresh_global), w, o)
    });
    for (i, (h, f)) in host.iter().zip(&fresh).enumerate() {
        assert_eq!(h[0], f[0], "step {i}: kept {h:?}, read afresh {f:?}");
    }
    let (read, vouched): (i64, i64) = host
        .iter()
        .fold((0, 0), |(a, b), o| (a + o[1] as i64, b + o[2] as i64));
    let frees = host.iter().filter(|o| o[0] == 1).count();
    assert!(
        vouched > 3 * read && frees > 200,
        "{read} words read, {vouched} pixels vouched for, {frees} free answers"
    );
    probe_each(
        &img,
        &mut global,
        "reflex_probe_known",
        &asks,
        KNOWN_IN_WORDS,
        &host,
        "step",
    );
    assert_eq!(global, host_global, "the writes left the same global RAM");
    eprintln!(
        "{} known-column steps: {read} words read, {vouched} pixels vouched for, {frees} free",
        host.len()
    );
}

/// End to end, with the C-space boards redrawing moving obstacles (their differential jobs,
/// the generations raised as they write): every window the reflex publishes as free (not
/// escaping, trapped, holding or waiting) is free in the map as it stands right after the
/// reflex's pass. The known columns vouch for most of it without a read, so a column they
/// failed to read again after a redraw would show here as a marked pixel inside a window.
/// Passes in a plant step where a C-space board also ran are skipped (its job may have
/// written after the reflex read).
#[test]
fn every_published_window_is_free_in_the_map_among_moving_obstacles() {
    use sim_host::campaign::{scene, Kind, Place};
    use sim_host::sim::Sim;
    use vme_map::records::reflex_flags as rf;
    use vme_map::{BoardSlot, GlobalBus};
    let (mut checked, mut pixels, mut vouched) = (0u64, 0u64, 0u64);
    for index in [3, 71, 108, 250, 400] {
        let s = scene(Kind::Moving, Place::Reach, 1, index);
        let mut sim = Sim::new(s.config.clone());
        let beat = |sim: &mut Sim, id: BoardId| sim.bus().read_u32(BoardSlot::of(id).heartbeat());
        let (mut reflex_hb, mut cspace_hb) = (0, 0);
        while !sim.done() {
            sim.step();
            let (r, c) = (
                beat(&mut sim, BoardId::Reflex),
                beat(&mut sim, BoardId::Cspace0),
            );
            let (reflex_ran, cspace_ran) = (r != reflex_hb, c != cspace_hb);
            (reflex_hb, cspace_hb) = (r, c);
            if !reflex_ran || cspace_ran {
                continue;
            }
            let Ok((sub, _)) = vme_map::REFLEX_SUBGOAL.read(&mut sim.bus()) else {
                continue;
            };
            let Ok((st, _)) = vme_map::REFLEX_STATUS.read(&mut sim.bus()) else {
                continue;
            };
            let not_free = rf::ESCAPING | rf::TRAPPED | rf::HOLD | rf::WAITING;
            if sub.flags & not_free != 0 || sub.cycle == 0 {
                continue;
            }
            // Bytes: first theta1 pixel, theta1 pixels, first theta2 pixel, theta2 pixels.
            let w = st.window;
            let (a, n1, b, n2) = (w >> 24, (w >> 16) & 0xFF, (w >> 8) & 0xFF, w & 0xFF);
            let mut g = sim.bus();
            for i in 0..n1 {
                let i1 = (a + i) % 128;
                for j in 0..n2 {
                    let i2 = (b + j) % 128;
                    let word = g.read_u32(vme_map::layout::cspace_counter(i1, i2, 0))
                        | g.read_u32(vme_map::layout::CSPACE_STRIPES + 4 * i1);
                    assert_eq!(
                        word,
                        0,
                        "scene {index} at {:.4} s: pixel ({i1}, {i2}) of the published window \
                         {a}+{n1} x {b}+{n2} is marked (flags {:#x})",
                        sim.t_s(),
                        sub.flags
                    );
                }
            }
            checked += 1;
            pixels += (n1 * n2) as u64;
            vouched += st.known as u64;
        }
    }
    assert!(
        checked > 5_000 && vouched > pixels / 4,
        "{checked} windows, {pixels} pixels, {vouched} vouched for by the known columns"
    );
    eprintln!("{checked} published windows free in the map ({pixels} pixels, {vouched} vouched for without a read)");
}

/// The reflex's axis arithmetic (`prepare`, on the 68020 the runtime's `__reflex_prepare`)
/// on the image against the host, word for word: arms anywhere within a few turns, at rest
/// or up to 60 rad/s either way, arrest points ahead or behind, previous subgoals and goals
/// near or far, latencies of 1-10 ms passes, margins as the window gives them; and a few
/// extremes (speeds and angles whose products saturate nothing but fill the words). Also
/// checks that the answers take every branch (the arrest point outside and inside the
/// previous subgoal's span, either sign of speed, the rest speed's floor). Prints the
/// image's cycles per axis.
#[test]
fn the_reflex_images_axes_match_the_host() {
    use reflex::script::{scripted_prepare, PREPARE_IN_WORDS, PREPARE_OUT_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let mut rng = Rng::new(33);
    let n = 600;
    let mut asks: Vec<i32> = Vec::new();
    for k in 0..n {
        let mut r = |m: u64| (rng.next_u64() % m) as i64;
        let mut ask = [0i32; PREPARE_IN_WORDS];
        ask[0] = k % 2;
        for a in 0..2 {
            let theta = r(40_000_001) - 20_000_000;
            let omega = match k % 5 {
                0 => r(40_001) - 20_000, // at rest: below and about the rest speed
                _ => r(120_000_001) - 60_000_000,
            };
            let arrest = theta + omega / 8 + r(400_001) - 200_000;
            ask[1 + a] = theta as i32;
            ask[3 + a] = omega as i32;
            ask[5 + a] = arrest as i32;
            // The previous subgoal near the arm, across the map, or just beyond the arrest
            // point (the arm heading for it: the arrest point inside its span); its units
            // within a few of the host's conversion (the reflex keeps them as it converted
            // them).
            let prev = match k % 3 {
                0 => theta + r(4_000_001) - 2_000_000,
                1 => theta + r(60_001) - 30_000,
                _ => arrest + (arrest - theta).signum() * r(20_001),
            };
            ask[7 + a] = prev as i32;
            ask[9 + a] = reflex::urad_to_u(prev as i32) + r(5) as i32 - 2;
            ask[11 + a] = reflex::urad_to_u((theta + r(6_000_001) - 3_000_000) as i32);
        }
        let lat_us = 2 * (1000 + r(9001)) + 500;
        ask[13] = (lat_us * 4295) as i32;
        ask[14] = 64 + r(3000) as i32;
        ask[15] = 64 + r(1500) as i32;
        if k < 4 {
            // Extremes: the fastest speeds and far angles either way.
            let s = if k % 2 == 0 { 1 } else { -1 };
            ask[1] = s * 2_000_000_000;
            ask[3] = s * 2_000_000_000;
            ask[5] = -s * 2_000_000_000;
        }
        asks.extend_from_slice(&ask);
    }
    let host = host_each::<i32, PREPARE_IN_WORDS, PREPARE_OUT_WORDS>(&asks, scripted_prepare);
    let cycles = probe_each(
        &img,
        &mut global,
        "reflex_probe_prepare",
        &asks,
        PREPARE_IN_WORDS,
        &host,
        "axis",
    );
    // Every branch taken: the base span wider than the arrest point alone (outside) and
    // not, speeds both ways, the stop time at the rest speed's floor and above it.
    let outside = (0..n as usize)
        .filter(|&i| {
            let (w, o) = (&asks[i * PREPARE_IN_WORDS..], &host[i]);
            let a = (w[0] & 1) as usize;
            let arrest = reflex::urad_to_u(w[5 + a]);
            let (theta, g) = (o[0], w[9 + a]);
            let tol = reflex::MARGIN_U / 2;
            arrest < theta.min(g) - tol || theta.max(g) + tol < arrest
        })
        .count();
    let backward = (0..n as usize)
        .filter(|&i| asks[i * PREPARE_IN_WORDS + 3 + (asks[i * PREPARE_IN_WORDS] & 1) as usize] < 0)
        .count();
    let floor = host.iter().map(|o| o[3]).min().unwrap();
    let floored = host.iter().filter(|o| o[3] == floor).count();
    assert!(
        outside > 50 && outside < n as usize - 50 && backward > 50 && floored > 20 && floored < 300,
        "{outside} outside, {backward} backward, {floored} at the stop time's floor"
    );
    let mean = cycles.iter().sum::<u64>() / cycles.len() as u64;
    eprintln!(
        "{n} axes: {mean} cycles an axis on average (probe call included), {} at most",
        cycles.iter().max().unwrap()
    );
}

/// The stall clock (`reflex::stall_flags`, on the 68020 the runtime's `__reflex_stall`) on
/// the image against the host, word for word: the arm at or near the goal or far from it,
/// at rest or moving about the rest speed, the subgoal at the goal, kept or moved about a
/// quarter pixel from the clock's, the clock's time just before, about and long before the
/// stall limit and wrapping round. Also checks that every flag is set and cleared and the
/// clock both kept and restarted. Prints the image's cycles per answer.
#[test]
fn the_reflex_images_stall_clocks_match_the_host() {
    use reflex::script::{scripted_stall, STALL_IN_WORDS, STALL_OUT_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let mut rng = Rng::new(44);
    let n = 800;
    let mut asks: Vec<i32> = Vec::new();
    for k in 0..n {
        let mut r = |m: u64| (rng.next_u64() % m) as i32;
        let mut ask = [0i32; STALL_IN_WORDS];
        for a in 0..2 {
            let goal = r(12_000_001) - 6_000_000;
            let theta = goal
                + match k % 3 {
                    0 => r(3_201) - 1_600,
                    1 => r(8_001) - 4_000,
                    _ => r(2_000_001) - 1_000_000,
                };
            ask[a] = theta;
            ask[2 + a] = if k % 2 == 0 {
                r(100_001) - 50_000
            } else {
                r(20_000_001) - 10_000_000
            };
            ask[4 + a] = goal;
            ask[6 + a] = if k % 5 == 0 {
                goal
            } else {
                theta + r(4_001) - 2_000
            };
            ask[8 + a] = ask[6 + a] + r(2_001) - 1_000;
        }
        let now = r(i32::MAX as u64);
        ask[10] = match k % 4 {
            0 => now - r(400_000),
            1 => now - 199_000 - r(2_000),
            2 => now + r(1_000_000),
            _ => now - r(i32::MAX as u64),
        };
        ask[11] = now;
        asks.extend_from_slice(&ask);
    }
    let host = host_each::<i32, STALL_IN_WORDS, STALL_OUT_WORDS>(&asks, scripted_stall);
    let cycles = probe_each(
        &img,
        &mut global,
        "reflex_probe_stall",
        &asks,
        STALL_IN_WORDS,
        &host,
        "stall",
    );
    use vme_map::records::reflex_flags as rf;
    for bit in [rf::AT_GOAL, rf::ARRIVED, rf::STALLED] {
        let set = host.iter().filter(|o| o[0] as u32 & bit != 0).count();
        assert!(
            set > 20 && set < n - 20,
            "flag {bit:#x} set in {set} of {n}"
        );
    }
    let restarted = (0..n)
        .filter(|&i| host[i][3] == asks[i * STALL_IN_WORDS + 11])
        .count();
    assert!(
        restarted > 50 && restarted < n - 50,
        "{restarted} restarted of {n}"
    );
    let mean = cycles.iter().sum::<u64>() / cycles.len() as u64;
    eprintln!("{n} stall answers: {mean} cycles an answer on average (probe call included)");
}

/// The goal's clamp into the window (`reflex::clamp_into`, on the 68020 the runtime's
/// `__reflex_clamp_into`) on the image against the host: goals inside, below and above
/// spans of 1-40 pixels anywhere within a few turns, with keeps that leave the span room or
/// not (then its middle). Also checks that each case occurs. Prints the image's cycles.
#[test]
fn the_reflex_images_goal_clamps_match_the_host() {
    use reflex::script::{scripted_clamp, CLAMP_IN_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let mut rng = Rng::new(55);
    let n = 800;
    let mut asks: Vec<i32> = Vec::new();
    let mut cases = [0usize; 4]; // inside, below, above, narrow
    for _ in 0..n {
        let mut r = |m: u64| (rng.next_u64() % m) as i32;
        let lo = r(1_001) - 500;
        let hi = lo + r(40);
        let keep = 64 + r(3_000);
        let goal_u = lo * 256 + r(((hi - lo + 1) * 256 + 4_000) as u64) - 2_000;
        let goal_urad = reflex::u_to_urad(goal_u) + r(3) - 1;
        let (l, h) = (lo * 256 + keep, (hi + 1) * 256 - 1 - keep);
        cases[if h < l {
            3
        } else if goal_u < l {
            1
        } else if goal_u > h {
            2
        } else {
            0
        }] += 1;
        asks.extend_from_slice(&[goal_urad, goal_u, lo, hi, keep]);
    }
    assert!(
        cases.iter().all(|&c| c > 50),
        "inside, below, above, narrow: {cases:?}"
    );
    let host = host_each::<i32, CLAMP_IN_WORDS, 1>(&asks, scripted_clamp);
    let cycles = probe_each(
        &img,
        &mut global,
        "reflex_probe_clamp",
        &asks,
        CLAMP_IN_WORDS,
        &host,
        "clamp",
    );
    let mean = cycles.iter().sum::<u64>() / cycles.len() as u64;
    eprintln!("{n} clamps: {mean} cycles a clamp on average (probe call included)");
}

/// The health monitor's entry readings (`reflex::health::Monitor::entry`, on the 68020 the
/// runtime's `__reflex_health_entry`) on the image against the host, step for step on one
/// monitor: entries read in turn and at random, claimed and free, their words changing or
/// standing still for up to 40 ms, tracked, undrawn or neither, lagging by up to 30 mm, the
/// clock wrapping once. Also checks that every verdict is set and cleared and the returned
/// mask both ways. Prints the image's cycles per step.
#[test]
fn the_reflex_images_health_entries_match_the_host() {
    use reflex::script::{scripted_health_entry, HEALTH_IN_WORDS, HEALTH_OUT_WORDS};
    let img = Image::load(&images_dir().join("reflex.elf")).unwrap();
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let mut rng = Rng::new(66);
    let n = 1500;
    let mut asks: Vec<i32> = Vec::new();
    let mut now = u32::MAX - 3_000_000; // wraps about a fifth of the way in
    let mut words = [[0i32; 2]; 6];
    let mut modes = [[1i32, 0, 0]; 6];
    for k in 0..n {
        let mut r = |m: u64| (rng.next_u64() % m) as i32;
        now = now.wrapping_add(r(3_000) as u32);
        let i = if k % 2 == 0 {
            (k / 2) % 6
        } else {
            r(6) as usize
        };
        // Words change now and then, claims come and go.
        if r(8) == 0 {
            words[i][0] = if r(3) == 0 { 0 } else { 1 + r(3) };
        }
        if r(6) == 0 {
            words[i][1] += 1;
        }
        // Drawn or not, and how far behind, for a while (lagging takes 100 ms of it).
        if r(25) == 0 {
            modes[i] = match r(6) {
                0 => [0, 1, r(30_000)],
                1 => [0, 0, r(30_000)],
                2 | 3 => [1, 0, 15_000 + r(15_000)],
                _ => [1, 0, r(15_001)],
            };
        }
        let [tracked, undrawn, lag] = modes[i];
        asks.extend_from_slice(&[
            i as i32,
            words[i][0],
            words[i][1],
            tracked,
            undrawn,
            lag,
            now as i32,
        ]);
    }
    let mut m = reflex::health::Monitor::new();
    let host = host_each::<i32, HEALTH_IN_WORDS, HEALTH_OUT_WORDS>(&asks, |w, o| {
        scripted_health_entry(&mut m, w, o)
    });
    let cycles = probe_each(
        &img,
        &mut global,
        "reflex_probe_health",
        &asks,
        HEALTH_IN_WORDS,
        &host,
        "health entry",
    );
    for (k, what) in [(0, "returned"), (1, "torn"), (2, "lagging"), (3, "behind")] {
        let set = host.iter().filter(|o| o[k] != 0).count();
        assert!(set > 30 && set < n - 30, "{what} in {set} of {n} steps");
    }
    let mean = cycles.iter().sum::<u64>() / cycles.len() as u64;
    eprintln!("{n} health steps: {mean} cycles a step on average (probe call included)");
}
