//! Firmware functions called one at a time on the emulated 68020, against host references.

use sim_host::emu::EmuBoard;
use sim_host::image::Image;
use system_tests::{board_of, put_word, ram_word};
use vme_map::{ArrayBus, BoardId, GlobalBus, GLOBAL_RAM_SIZE};

fn board() -> (EmuBoard, Image, Vec<u8>) {
    board_of(BoardId::Reflex)
}

/// Routine `name` (C ABI, 32-bit arguments and result) from the first board image that
/// links it (the servo's first), called on the emulated CPU.
fn any_routine(name: &str) -> impl FnMut(&[i32]) -> i32 {
    let (mut b, f, mut g) = [
        BoardId::Servo,
        BoardId::Sensing,
        BoardId::Reflex,
        BoardId::Planner,
        BoardId::Cspace0,
    ]
    .into_iter()
    .find_map(|id| {
        let (b, img, g) = board_of(id);
        img.symbol(name).map(|f| (b, f, g))
    })
    .unwrap_or_else(|| panic!("{name} in no board image"));
    move |args| {
        let args: Vec<u32> = args.iter().map(|&a| a as u32).collect();
        b.call(&mut g, f, &args, 10_000).unwrap().0 as i32
    }
}

/// Scratch area in the board's RAM for test buffers.
const BUF: u32 = 0x000C_0000;

#[test]
fn memcpy_memmove_memset_memcmp_match_the_host() {
    let (mut b, img, mut g) = board();
    let f = |n: &str| img.symbol(n).unwrap_or_else(|| panic!("{n} not in image"));
    let pattern: Vec<u8> = (0..160u32).map(|i| (i * 37 + 11) as u8).collect();
    // Every length to 70 (the 32-byte passes, the 0-7 longs left, a word, a byte) at even
    // and odd ends, and the longer ones.
    let mut cases = vec![(3u32, 97u32, 64u32), (2, 100, 150), (0, 98, 96)];
    for n in 0..=70 {
        for (d, s) in [(0, 100), (2, 102), (0, 102), (1, 100), (0, 101), (1, 101)] {
            cases.push((d, s, n));
        }
    }
    for (dst_off, src_off, n) in cases {
        b.ram[BUF as usize..BUF as usize + 512].fill(0xEE);
        b.ram[(BUF + 256) as usize..(BUF + 416) as usize].copy_from_slice(&pattern);
        let (dst, src) = (BUF + dst_off, BUF + 256 + src_off - 100);
        let (ret, _) = b
            .call(&mut g, f("memcpy"), &[dst, src, n], 100_000)
            .expect("memcpy returns");
        assert_eq!(ret, dst);
        let want = &b.ram[src as usize..(src + n) as usize].to_vec();
        assert_eq!(
            &b.ram[dst as usize..(dst + n) as usize],
            &want[..],
            "memcpy({dst_off},{src_off},{n})"
        );
        assert_eq!(b.ram[(dst + n) as usize], 0xEE, "memcpy wrote past the end");
        if dst_off > 0 {
            assert_eq!(
                b.ram[(dst - 1) as usize],
                0xEE,
                "memcpy wrote before the start"
            );
        }
    }
    // Overlapping memmove both ways.
    for (d, s, n) in [
        (BUF + 5, BUF, 40),
        (BUF, BUF + 5, 40),
        (BUF, BUF + 4, 150),
        (BUF + 4, BUF, 150),
        (BUF + 2, BUF + 6, 77),
    ] {
        b.ram[BUF as usize..BUF as usize + 160].copy_from_slice(&pattern);
        let mut host = pattern.clone();
        let (d0, s0) = ((d - BUF) as usize, (s - BUF) as usize);
        host.copy_within(s0..s0 + n as usize, d0);
        b.call(&mut g, f("memmove"), &[d, s, n], 100_000).unwrap();
        assert_eq!(&b.ram[BUF as usize..BUF as usize + 160], &host[..]);
    }
    b.call(&mut g, f("memset"), &[BUF + 3, 0x1A5, 9], 100_000)
        .unwrap();
    assert_eq!(&b.ram[(BUF + 3) as usize..(BUF + 12) as usize], &[0xA5; 9]);
    assert_ne!(b.ram[(BUF + 12) as usize], 0xA5);
    // Every length to 70 at even and odd starts, zero (no spreading) and not, and a long one.
    let mut sets: Vec<(u32, u32, u32)> = vec![(0, 0x5A, 200), (1, 0, 150)];
    for n in 0..=70 {
        for (d, c) in [(0, 0), (2, 0x1A5), (1, 0), (3, 0xC3)] {
            sets.push((d, c, n));
        }
    }
    for (d, c, n) in sets {
        b.ram[BUF as usize..BUF as usize + 256].fill(0xEE);
        let (ret, _) = b
            .call(&mut g, f("memset"), &[BUF + d, c, n], 100_000)
            .expect("memset returns");
        assert_eq!(ret, BUF + d);
        let (lo, hi) = ((BUF + d) as usize, (BUF + d + n) as usize);
        assert!(
            b.ram[lo..hi].iter().all(|&x| x == c as u8),
            "memset({d},{c:#x},{n})"
        );
        assert_eq!(b.ram[hi], 0xEE, "memset({d},{c:#x},{n}) wrote past the end");
        if d > 0 {
            assert_eq!(
                b.ram[lo - 1],
                0xEE,
                "memset({d},{c:#x},{n}) wrote before the start"
            );
        }
    }
    b.ram[BUF as usize..BUF as usize + 4].copy_from_slice(b"abcd");
    b.ram[(BUF + 8) as usize..(BUF + 12) as usize].copy_from_slice(b"abzd");
    let cmp = |b: &mut EmuBoard, g: &mut Vec<u8>, n| {
        b.call(g, f("memcmp"), &[BUF, BUF + 8, n], 100_000)
            .unwrap()
            .0 as i32
    };
    assert_eq!(cmp(&mut b, &mut g, 2), 0);
    assert!(cmp(&mut b, &mut g, 4) < 0);
}

#[test]
fn the_critical_section_masks_and_restores_interrupts() {
    let (mut b, img, mut g) = board();
    let f = |n: &str| img.symbol(n).unwrap_or_else(|| panic!("{n} not in image"));
    b.cpu.set_sr(0x2300);
    let (old, _) = b.call(&mut g, f("__rt_sr_mask_all"), &[], 1000).unwrap();
    assert_eq!(old, 0x2300);
    assert_eq!(b.cpu.get_sr() & 0x0700, 0x0700, "mask raised to 7");
    b.call(&mut g, f("__rt_sr_restore"), &[0x2300], 1000)
        .unwrap();
    // The system byte (supervisor bit, interrupt mask) is the contract; the condition codes
    // are not preserved across calls in the C ABI.
    assert_eq!(b.cpu.get_sr() & 0xFF00, 0x2300);
    b.call(&mut g, f("__rt_sr_restore"), &[0x2700], 1000)
        .unwrap();
    assert_eq!(b.cpu.get_sr() & 0xFF00, 0x2700);
}

#[test]
fn cas_swaps_only_when_the_word_matches() {
    let (mut b, img, mut g) = board();
    let cas = img.symbol("__vme_cas32").expect("__vme_cas32");
    let addr = vme_map::GLOBAL_RAM_BASE + 0x800;
    g[0x800..0x804].copy_from_slice(&7u32.to_be_bytes());
    let (found, _) = b.call(&mut g, cas, &[addr, 7, 9], 1000).unwrap();
    assert_eq!(found, 7);
    assert_eq!(u32::from_be_bytes(g[0x800..0x804].try_into().unwrap()), 9);
    let (found, _) = b.call(&mut g, cas, &[addr, 7, 11], 1000).unwrap();
    assert_eq!(found, 9, "no swap: the word was 9");
    assert_eq!(u32::from_be_bytes(g[0x800..0x804].try_into().unwrap()), 9);
}

/// A map word as the readers' tests draw them: zero a quarter of the time, one bit a
/// quarter, else a sparse random word.
fn sparse_word(rng: &mut sim_host::sim::Rng) -> u32 {
    match rng.next_u64() % 4 {
        0 => 0,
        1 => 1 << (rng.next_u64() % 32),
        _ => rng.next_u64() as u32 & (rng.next_u64() as u32),
    }
}

/// The planner's map reader (`__vme_nonzero_bits`, the runtime's assembly) against the
/// host's bus, on rows of random words with runs of zeros.
#[test]
fn nonzero_bits_matches_the_host_bus() {
    let (mut b, img, mut g) = board_of(BoardId::Planner);
    let f = img
        .symbol("__vme_nonzero_bits")
        .expect("__vme_nonzero_bits in the planner image");
    let mut rng = sim_host::sim::Rng::new(7);
    for case in 0..200u32 {
        let off = 0x1000 + 128 * case;
        for k in 0..32u32 {
            let v = sparse_word(&mut rng);
            ArrayBus::new(&mut g).write_u32(off + 4 * k, v);
        }
        let want = ArrayBus::new(&mut g).nonzero_bits(off);
        let (got, cycles) = b
            .call(&mut g, f, &[vme_map::GLOBAL_RAM_BASE + off], 10_000)
            .unwrap();
        assert_eq!(got, want, "case {case}");
        assert!(cycles < 2_000, "{cycles} cycles");
    }
}

/// The escape's column reader (`__vme_nonzero_bits_strided`, the runtime's assembly)
/// against the host's bus: runs of 1-32 words of a C-space map column (512 bytes apart)
/// and of a row (4 bytes apart).
#[test]
fn nonzero_bits_strided_matches_the_host_bus() {
    let (mut b, img, mut g) = board_of(BoardId::Reflex);
    let f = img
        .symbol("__vme_nonzero_bits_strided")
        .expect("__vme_nonzero_bits_strided in the reflex image");
    let mut rng = sim_host::sim::Rng::new(11);
    for case in 0..200u32 {
        let stride = if case % 4 == 0 { 4 } else { 512 };
        let n = 1 + (rng.next_u64() % 32) as u32;
        let off = 0x1_0000 + 4 * (rng.next_u64() % 128) as u32;
        for k in 0..n {
            let v = sparse_word(&mut rng);
            ArrayBus::new(&mut g).write_u32(off + stride * k, v);
        }
        let want = ArrayBus::new(&mut g).nonzero_bits_strided(off, n, stride);
        let last = vme_map::GLOBAL_RAM_BASE + off + (n - 1) * stride;
        let (got, cycles) = b.call(&mut g, f, &[last, n, stride], 10_000).unwrap();
        assert_eq!(got, want, "case {case}: {n} words {stride} bytes apart");
        assert!(cycles < 1_000, "{cycles} cycles");
    }
}

/// `__fx_mul_shr` (any shift) and the fixed-shift `__fx_mul_shrN` that `fx::mul_shr` calls
/// for the shifts the firmware uses most, against the host's.
#[test]
fn the_fixed_point_multiply_matches_the_host_bit_for_bit() {
    let mut f = any_routine("__fx_mul_shr");
    let mut rng = sim_host::sim::Rng::new(42);
    let edge = [
        0,
        1,
        -1,
        2,
        -2,
        65536,
        -65536,
        i32::MAX,
        i32::MIN,
        i32::MAX - 1,
        i32::MIN + 1,
        1 << 30,
        -(1 << 30),
    ];
    let mut cases = Vec::new();
    for &a in &edge {
        for &bb in &edge {
            for sh in [1, 8, 16, 24, 31, 32] {
                cases.push((a, bb, sh));
            }
        }
    }
    for _ in 0..3000 {
        let a = rng.next_u64() as i32 >> (rng.next_u64() % 31);
        let bb = rng.next_u64() as i32 >> (rng.next_u64() % 31);
        let sh = 1 + (rng.next_u64() % 32) as u32;
        cases.push((a, bb, sh));
    }
    for &(a, bb, sh) in &cases {
        let want = servo::fx::host_mul_shr(a, bb, sh);
        assert_eq!(f(&[a, bb, sh as i32]), want, "mul_shr({a}, {bb}, {sh})");
    }
    for sh in [8u32, 16, 17, 24, 32] {
        let mut f = any_routine(&format!("__fx_mul_shr{sh}"));
        // The cases, and values just inside and outside the range that fits.
        let mut pairs: Vec<(i32, i32)> = cases.iter().map(|&(a, b, _)| (a, b)).collect();
        for k in -3..=3 {
            let top = (1i64 << (31 + sh)) / 65536 + k;
            pairs.push(((top.clamp(i32::MIN as i64, i32::MAX as i64)) as i32, 65536));
            pairs.push(((-top).clamp(i32::MIN as i64, i32::MAX as i64) as i32, 65536));
        }
        if sh < 32 {
            // Products on both sides of each end of the range, rounding included: T =
            // 2^(sh-1) (2^32 - 1) = 2^(sh-1) 65535 65537 is the least that rounds past
            // i32::MAX, -2^(sh-1) (2^32 + 1) = -2^(sh-1) 641 6700417 the least negative that
            // still rounds to i32::MIN (one below it does not fit).
            let j = sh.saturating_sub(16) as i32;
            let (a, b) = (65537i32 << j, 65535i32 << (sh as i32 - 1 - j));
            pairs.extend([(a, b), (a - 1, b), (-a, b), (-a + 1, b), (b, -a), (-b, -a)]);
            let j = sh.saturating_sub(22) as i32;
            let (a, b) = (-6700417i32 << j, 641i32 << (sh as i32 - 1 - j));
            pairs.extend([(a, b), (a - 1, b), (-a, -b), (-a + 1, -b), (b, a), (-b, -a)]);
        }
        for (a, bb) in pairs {
            let want = servo::fx::host_mul_shr(a, bb, sh);
            assert_eq!(f(&[a, bb]), want, "mul_shr{sh}({a}, {bb})");
        }
    }
}

#[test]
fn the_fixed_point_divide_matches_the_host_bit_for_bit() {
    let mut f = any_routine("__fx_div");
    let mut rng = sim_host::sim::Rng::new(7);
    let edge = [
        0,
        1,
        -1,
        3,
        -3,
        65536,
        -65536,
        i32::MAX,
        i32::MIN,
        1 << 30,
        -(1 << 30),
    ];
    let mut cases = Vec::new();
    for &n in &edge {
        for &d in &edge {
            for sh in [0, 1, 16, 24, 31] {
                cases.push((n, d, sh));
            }
        }
    }
    for _ in 0..3000 {
        let n = rng.next_u64() as i32 >> (rng.next_u64() % 31);
        let d = rng.next_u64() as i32 >> (rng.next_u64() % 31);
        let sh = (rng.next_u64() % 32) as u32;
        cases.push((n, d, sh));
    }
    for (n, d, sh) in cases {
        let want = servo::fx::host_div_shl(n, d, sh);
        assert_eq!(f(&[n, d, sh as i32]), want, "div_shl({n}, {d}, {sh})");
    }
}

/// The square root's interpolated table (`SQRT_Q16` in crates/rt/asm/servo.S) gives the
/// floor or one less for every n in [2^30, 2^32), which is what lets one `MULU.W` take it up
/// to the floor. The image's table must be T[i] = floor(2^19 sqrt(i)), i = 256..=1024 (so
/// every chord runs below the concave root: never above the floor), and in every segment
/// the root can exceed the interpolation, in Q8, by at most the chord's largest gap (where
/// the root's slope 128 / sqrt(n) meets the chord's), plus one for the product's floor and
/// 63 / 2^22 of the chord's rise for the six low bits of n left out, which must stay below
/// one unit of the root (256). (An exhaustive check of all 3.2e9 n on the host agreed:
/// never above the floor, at most one below, largest gap 0.024.)
#[test]
fn the_square_root_table_interpolates_to_within_one_of_the_floor() {
    let (b, img, _) = board_of(BoardId::Servo);
    let table = img
        .symbol("__fx_sqrt_table")
        .expect("__fx_sqrt_table in the image");
    let t: Vec<u64> = (0..=768u32)
        .map(|k| ram_word(&b.ram, table + 4 * k) as u64)
        .collect();
    for (k, &v) in t.iter().enumerate() {
        let n = (256 + k as u128) << 38;
        assert!(
            (v as u128).pow(2) <= n && (v as u128 + 1).pow(2) > n,
            "T[{}] = {v}",
            256 + k
        );
    }
    let mut worst = 0f64;
    for k in 0..768usize {
        let x0 = ((256 + k) as f64) * 4_194_304.0;
        let (t0, d) = (t[k] as f64, (t[k + 1] - t[k]) as f64);
        assert!(
            d < 65536.0,
            "segment {k}: a rise of {d} does not fit MULU.W"
        );
        let chord = |n: f64| t0 + d * (n - x0) / 4_194_304.0;
        let at = (128.0 * 4_194_304.0 / d)
            .powi(2)
            .clamp(x0, x0 + 4_194_303.0);
        let gap = [x0, at, x0 + 4_194_303.0]
            .iter()
            .map(|&n| 256.0 * n.sqrt() - chord(n))
            .fold(f64::MIN, f64::max);
        worst = worst.max(gap + 1.0 + d * 63.0 / 4_194_304.0);
    }
    assert!(
        worst < 256.0,
        "the interpolation falls short by up to {worst} / 256"
    );
}

/// `__fx_mul_floor_shr24` (fx::mul_floor_shr24, the reflex's urad-to-angle-unit
/// conversion) against the host's on the edges and random pairs.
#[test]
fn the_floor_multiply_matches_the_host_bit_for_bit() {
    let mut f = any_routine("__fx_mul_floor_shr24");
    let mut rng = sim_host::sim::Rng::new(13);
    let edges = [
        0,
        1,
        -1,
        87_496,
        1 << 23,
        -(1 << 23),
        1 << 24,
        i32::MAX,
        i32::MIN,
    ];
    let mut pairs: Vec<(i32, i32)> = edges
        .iter()
        .flat_map(|&a| edges.iter().map(move |&b| (a, b)))
        .collect();
    pairs.extend((0..2000).map(|_| (rng.next_u64() as i32, rng.next_u64() as i32)));
    pairs.extend((0..2000).map(|_| ((rng.next_u64() as i32) >> 4, 87_496)));
    for (a, b) in pairs {
        assert_eq!(f(&[a, b]), fx::host_mul_floor_shr24(a, b), "{a} * {b}");
    }
}

#[test]
fn the_fixed_point_square_root_matches_the_host_bit_for_bit() {
    let mut f = any_routine("__fx_sqrt_q16");
    let mut rng = sim_host::sim::Rng::new(11);
    let mut cases = vec![
        0,
        1,
        2,
        3,
        4,
        -1,
        i32::MIN,
        i32::MAX,
        65535,
        65536,
        65537,
        1 << 30,
    ];
    for _ in 0..3000 {
        cases.push(rng.next_u64() as i32 >> (rng.next_u64() % 32));
    }
    // Around perfect squares (where a root one off shows), and every top byte of the
    // shifted input (the table-seeded path).
    for k in (1..46341i32).step_by(37) {
        cases.extend([k * k - 1, k * k, k * k + 1]);
    }
    for b in 0..256u32 {
        for low in [0u32, 0x7F_FFFF, 0xFF_FFFF] {
            cases.push(((b << 24 | low) >> 1) as i32);
        }
    }
    // Both ends and the middle of every segment of the interpolated table: n = x for x in
    // [2^30, 2^31), n = 4 x for x in [2^29, 2^30).
    for i in 256..1024u32 {
        for low in [0u32, 0x20_0000, 0x3F_FFFF] {
            let n = i << 22 | low;
            cases.push(if i < 512 { n as i32 } else { (n >> 2) as i32 });
        }
    }
    for x in cases {
        assert_eq!(f(&[x]), servo::fx::host_sqrt_q16(x), "sqrt_q16({x})");
    }
}

/// The image's arrest-log look-up (`__servo_at_age`, which `ArrestLog::at_age` calls on
/// the 68020) against the host's, on logs of 0 to 300 passes with steady, jittered and
/// wrapping clocks, for ages from 0 to beyond the ring; and its cost, printed: the compiled
/// loop took ~27,000 cycles.
#[test]
fn the_arrest_log_look_up_matches_the_host() {
    use servo::arrest_log::{ArrestLog, PASSES};
    let (mut b, img, mut g) = board_of(BoardId::Servo);
    let f = img
        .symbol("__servo_at_age")
        .expect("__servo_at_age in the image");
    let mut rng = sim_host::sim::Rng::new(5);
    let (mut cases, mut worst) = (0, 0u64);
    for (passes, start, step) in [
        (0u32, 0u32, 1000u32),
        (1, 5, 1000),
        (50, 0, 16_777),
        (127, 1 << 20, 8_389),
        (128, 0, 1000),
        (300, 0, 1000),
        (200, u32::MAX - 100_000, 1000),
    ] {
        let mut log = ArrestLog::new();
        let mut t = start;
        for k in 0..passes {
            t = t.wrapping_add(step + ((rng.next_u64() as u32) % 3));
            log.push(t, [k as i32, -(k as i32) * 7]);
        }
        let (n, kept, ts, arrest) = log.raw();
        put_word(&mut b.ram, BUF, n);
        put_word(&mut b.ram, BUF + 4, kept);
        for i in 0..PASSES {
            put_word(&mut b.ram, BUF + 8 + 4 * i as u32, ts[i]);
            put_word(
                &mut b.ram,
                BUF + 8 + 4 * PASSES as u32 + 8 * i as u32,
                arrest[i][0] as u32,
            );
            put_word(
                &mut b.ram,
                BUF + 12 + 4 * PASSES as u32 + 8 * i as u32,
                arrest[i][1] as u32,
            );
        }
        let (fb, out) = (BUF + 0x1000, BUF + 0x1010);
        put_word(&mut b.ram, fb, 11);
        put_word(&mut b.ram, fb + 4, (-12i32) as u32);
        let now = log.newest_t();
        let mut ages = vec![
            0,
            1,
            step,
            step * 20 + step / 2,
            step * 127,
            step * 128,
            u32::MAX / 4,
        ];
        ages.extend((0..20).map(|_| (rng.next_u64() as u32) % (step * 140)));
        for age in ages {
            for now in [now, now.wrapping_add(step / 2)] {
                let (_, cycles) = b
                    .call(&mut g, f, &[BUF, now, age, fb, out], 100_000)
                    .expect("the routine returns");
                let got = [
                    ram_word(&b.ram, out) as i32,
                    ram_word(&b.ram, out + 4) as i32,
                ];
                assert_eq!(
                    got,
                    log.at_age(now, age, [11, -12]),
                    "{passes} passes, age {age}"
                );
                worst = worst.max(cycles);
                cases += 1;
            }
        }
    }
    println!("__servo_at_age: {cases} look-ups, at most {worst} cycles");
    assert!(cases > 300);
}

/// The servo probes' scripted move, pass `i`: both encoders following a smoothstep toward a
/// link-1 move of 3 rad and a link-2 move of -1 rad over 300 passes (in counts: 32768 and
/// 8192 a turn), the timer advanced by `period` ticks with up to 7 of jitter from the
/// generator `s` (and by 25,000 more, over the 10 ms limit, at pass 400), and the link-1 goal
/// in urad (3 rad; out of range at passes 320-324). Returns the encoders, the timer and that
/// goal as probe input words.
fn servo_script(i: u32, period: u32, t: &mut u32, s: &mut u32) -> [u32; 4] {
    *s = s.wrapping_mul(1_103_515_245).wrapping_add(12_345);
    *t = t.wrapping_add(period + (*s >> 29) + if i == 400 { 25_000 } else { 0 });
    let x = (i as f64 / 300.0).min(1.0);
    let p = x * x * (3.0 - 2.0 * x);
    let c1 = (p * 3.0 / std::f64::consts::TAU * 32768.0) as i32;
    let c2 = (-p / std::f64::consts::TAU * 8192.0) as i32;
    let goal1: i32 = if (320..325).contains(&i) {
        30_000_000
    } else {
        3_000_000
    };
    [
        c1 as u16 as u32,
        c2 as u16 as u32,
        *t & 0xFFFF,
        goal1 as u32,
    ]
}

/// Writes `inputs` big-endian at [`BUF`] in the board's RAM, runs the probe `f(inputs, n,
/// out)` with `out` right after them, checks that it returns 0 and returns `out`.
fn run_probe(b: &mut EmuBoard, g: &mut [u8], f: u32, inputs: &[u32], n: u32) -> u32 {
    let (inp, out) = (BUF, BUF + 4 * inputs.len() as u32);
    for (k, w) in inputs.iter().enumerate() {
        put_word(&mut b.ram, inp + 4 * k as u32, *w);
    }
    let (ret, _) = b
        .call(g, f, &[inp, n, out], 1_000_000_000)
        .expect("the probe returns");
    assert_eq!(ret, 0);
    out
}

/// Private I/O registers as plain halfwords, as the servo image's board probe keeps them.
struct RamIo([u16; 32]);

impl regs::IoBus for RamIo {
    fn read16(&mut self, off: u32) -> u16 {
        self.0[off as usize / 2]
    }
    fn write16(&mut self, off: u32, val: u16) {
        self.0[off as usize / 2] = val;
    }
}

/// The servo image's whole main-loop pass (`Board::poll_ports`: the common pass in
/// `__servo_board_pass`, the rest in Rust; through its test probe) against the host's
/// `Board::poll`, pass for pass: the published servo state record (sequence and words), the
/// DAC and amplifier registers and the heartbeat must be identical. The script moves both
/// links and takes the subgoal record through never published, fresh, the same cycle
/// again, left untouched, stale, out of range, torn briefly and torn for long.
#[test]
fn the_servo_board_image_passes_like_the_host() {
    use regs::servo::{AMP_CTRL, DAC0, DAC1, ENC0, ENC1, TIMER};
    let (mut b, img, mut g) = board_of(BoardId::Servo);
    let f = img
        .symbol("servo_board_probe_run")
        .expect("servo_board_probe_run in the image");
    let n = 700u32;
    let mut inputs = Vec::new();
    let (mut t, mut s) = (0u32, 0x0bad_cafeu32);
    for i in 0..n {
        // ~1,500 passes a second.
        let [c1, c2, timer, goal1] = servo_script(i, 1333, &mut t, &mut s);
        let cycle = match i {
            100..=199 => i / 3,
            250..=289 => 250,
            _ => i,
        };
        // 0: published whole; 1: torn; 2: left as it was (never published at first).
        let mode = match i {
            0..=4 | 450..=455 => 2,
            340..=344 | 360..=375 => 1,
            _ => 0,
        };
        let goal2 = (-1_000_000i32) as u32;
        inputs.extend_from_slice(&[c1, c2, timer, goal1, goal2, cycle, mode]);
    }
    let out = run_probe(&mut b, &mut g, f, &inputs, n);
    let mut mem = vec![0u8; GLOBAL_RAM_SIZE as usize];
    let mut gb = ArrayBus::new(&mut mem);
    let mut io = RamIo([0; 32]);
    let mut host = board_servo::Board::with_links(&servo::params::TUNED_AT_IMAGE_HZ);
    let (sub, state) = (
        vme_map::REFLEX_SUBGOAL.offset(),
        vme_map::SERVO_STATE.offset(),
    );
    let mut driving = 0;
    for i in 0..n as usize {
        let w = &inputs[7 * i..7 * i + 7];
        use regs::IoBus;
        io.write16(ENC0, w[0] as u16);
        io.write16(ENC1, w[1] as u16);
        io.write16(TIMER, w[2] as u16);
        match w[6] {
            0 => vme_map::REFLEX_SUBGOAL.publish_raw(&mut gb, &[w[3], w[4], 0, w[5]]),
            1 => {
                let seq = gb.read_u32(sub);
                gb.write_u32(sub, seq | 1);
            }
            _ => {}
        }
        let hb = host.poll(&mut gb, &mut io);
        let mut want: Vec<u32> = (0..11).map(|k| gb.read_u32(state + 4 * k)).collect();
        // The state every other pass: the pass after the one that computed the arrest
        // points (the first did) publishes that pass's state, its count among it.
        assert_eq!(
            want[0],
            2 * (i as u32).div_ceil(2),
            "pass {i}: the state's sequence"
        );
        if i % 2 == 1 {
            assert_eq!(want[10], i as u32, "pass {i}: the count of the pass before");
        }
        want.extend([
            io.read16(DAC0) as u32,
            io.read16(DAC1) as u32,
            io.read16(AMP_CTRL) as u32,
            hb,
        ]);
        let got: Vec<u32> = (0..15)
            .map(|k| ram_word(&b.ram, out + 4 * (15 * i + k) as u32))
            .collect();
        assert_eq!(got, want, "pass {i}");
        driving += (want[11] != 0 && want[12] != 0) as u32;
    }
    assert!(
        driving > 100,
        "the script drives both links ({driving} passes)"
    );
}

/// The servo image's `Servo::step` (through its test probe) against the host's, pass for
/// pass, over scripted inputs: a link-1 move of 3 rad and a link-2 move of -1 rad with the
/// encoders following a smooth made-up trajectory, the timer at 750 Hz with jitter. DAC codes
/// and observed velocities must be identical.
#[test]
fn the_servo_image_steps_like_the_host() {
    let (mut b, img, mut g) = board_of(BoardId::Servo);
    let f = img
        .symbol("servo_probe_run")
        .expect("servo_probe_run in the image");
    const WORDS: usize = servo::Output::PROBE_WORDS;
    let n = 600u32;
    let mut inputs = Vec::new();
    let mut cycles = Vec::new();
    let (mut t, mut s) = (0u32, 0x1234_5678u32);
    for i in 0..n {
        // ~750 passes a second.
        let [c1, c2, timer, goal1] = servo_script(i, 2667, &mut t, &mut s);
        // The subgoal: none at start-up and torn for a while (u32::MAX), its cycle kept
        // for three passes (fresh, the same cycle again) and for 30 (1.33 ms passes: stale
        // after 15), out of range for a few passes.
        let cycle = match i {
            0..=4 | 340..=344 => u32::MAX,
            100..=199 => i / 3,
            250..=279 => 250,
            _ => i,
        };
        cycles.push(cycle);
        let goal2 = (-1_000_000i32) as u32;
        inputs.extend_from_slice(&[c1, c2, timer, goal1, goal2, cycle]);
    }
    let out = run_probe(&mut b, &mut g, f, &inputs, n);
    let mut host = servo::Servo::with_links(&servo::params::TUNED_AT_IMAGE_HZ);
    let (mut driving, mut faults) = (0, Vec::new());
    for i in 0..n as usize {
        let w = &inputs[6 * i..6 * i + 6];
        let o = host.step(&servo::Input {
            enc: [w[0] as u16, w[1] as u16],
            timer: w[2] as u16,
            subgoal: (cycles[i] != u32::MAX).then(|| servo::Subgoal {
                goal_urad: [w[3] as i32, w[4] as i32],
                cycle: cycles[i],
            }),
        });
        let got: Vec<i32> = (0..WORDS)
            .map(|k| ram_word(&b.ram, out + 4 * (WORDS * i + k) as u32) as i32)
            .collect();
        let want = o.probe_words().to_vec();
        assert_eq!(got, want, "pass {i}");
        driving += (o.dac[0] != 0 && o.dac[1] != 0) as u32;
        faults.extend(o.new_fault);
    }
    assert!(
        driving > 100,
        "the script drives both links ({driving} passes)"
    );
    use servo::Hold::*;
    assert_eq!(
        faults,
        [Stale, OutOfRange, Torn],
        "the script's faults, in order"
    );
}

/// The runtime's unsigned remainder (`__fx_rem_u32`: the 64-bit dividend form of DIVU.L)
/// against the host's `%`, including a zero divisor.
#[test]
fn the_unsigned_remainder_matches_the_host() {
    let (mut b, img, mut g) = board_of(BoardId::Cspace0);
    let f = img
        .symbol("__fx_rem_u32")
        .expect("__fx_rem_u32 in the cspace image");
    let mut rng = sim_host::sim::Rng::new(5);
    let mut cases: Vec<(u32, u32)> = vec![
        (0, 1),
        (7, 6),
        (u32::MAX, 6),
        (u32::MAX, u32::MAX),
        (5, 0),
        (123, 1),
    ];
    for _ in 0..2000 {
        let a = rng.next_u64() as u32 >> (rng.next_u64() % 32);
        let d = (rng.next_u64() as u32 >> (rng.next_u64() % 32)).max(1);
        cases.push((a, d));
    }
    for (a, d) in cases {
        let (got, _) = b.call(&mut g, f, &[a, d], 1_000).unwrap();
        assert_eq!(got, fx::rem_u32(a, d), "{a} % {d}");
        assert_eq!(got, a.checked_rem(d).unwrap_or(0));
    }
}

/// The record reader and writer (`__vme_read_words`, the runtime's assembly) copies exactly
/// the words asked for, in order, and nothing past them, from global RAM and to it.
#[test]
fn read_words_copies_the_words_asked_for() {
    let (mut b, img, mut g) = board_of(BoardId::Planner);
    let f = img
        .symbol("__vme_read_words")
        .expect("__vme_read_words in the planner image");
    let off = 0x2000u32;
    for k in 0..64u32 {
        ArrayBus::new(&mut g).write_u32(off + 4 * k, 0x1000_0000 + k * 0x0101);
    }
    // Every length to 40 (the eight-word passes and the 0-7 words left) and the longest.
    for n in (0u32..=40).chain([63]) {
        b.ram[BUF as usize..BUF as usize + 256].fill(0xEE);
        b.call(&mut g, f, &[vme_map::GLOBAL_RAM_BASE + off, BUF, n], 10_000)
            .unwrap();
        for k in 0..n as usize {
            let at = BUF as usize + 4 * k;
            let w = u32::from_be_bytes(b.ram[at..at + 4].try_into().unwrap());
            assert_eq!(w, 0x1000_0000 + k as u32 * 0x0101, "word {k} of {n}");
        }
        let past = BUF as usize + 4 * n as usize;
        assert_eq!(&b.ram[past..past + 4], &[0xEE; 4], "nothing past {n} words");
        // The other way (`MmioGlobal::write_words`, a record's publication): local RAM to
        // global, nothing past the words either.
        let to = 0x3000u32;
        for k in 0..64u32 {
            ArrayBus::new(&mut g).write_u32(to + 4 * k, 0xEEEE_EEEE);
        }
        b.call(&mut g, f, &[BUF, vme_map::GLOBAL_RAM_BASE + to, n], 10_000)
            .unwrap();
        for k in 0..n {
            let w = ArrayBus::new(&mut g).read_u32(to + 4 * k);
            assert_eq!(w, 0x1000_0000 + k * 0x0101, "word {k} of {n} written");
        }
        assert_eq!(
            ArrayBus::new(&mut g).read_u32(to + 4 * n),
            0xEEEE_EEEE,
            "nothing past {n} written"
        );
    }
}

/// The reflex's window test (`__vme_free_rows`, the runtime's assembly) against the host
/// bus's loop: random rectangles of the C-space map (two runs a row, the second possibly
/// empty, any count of rows) over rows with a few nonzero words scattered in: the count of
/// free rows it returns.
#[test]
fn free_rows_matches_the_host_bus() {
    use vme_map::layout::{cspace_counter, CSPACE_COUNTERS, CSPACE_SIDE};
    let (mut b, img, mut g) = board();
    let f = img
        .symbol("__vme_free_rows")
        .expect("__vme_free_rows in the reflex image");
    let mut rng = sim_host::sim::Rng::new(31);
    let stride = CSPACE_SIDE * CSPACE_COUNTERS;
    let mut blocked = 0;
    for case in 0..300u32 {
        for i2 in 0..128 {
            for i1 in 0..128 {
                let v = if rng.next_u64().is_multiple_of(600) {
                    1 << (rng.next_u64() % 32)
                } else {
                    0
                };
                ArrayBus::new(&mut g).write_u32(cspace_counter(i1, i2, 0), v);
            }
        }
        let n0 = 1 + (rng.next_u64() % 128) as u32;
        let a0 = (rng.next_u64() % (129 - n0 as u64)) as u32;
        let n1 = if case.is_multiple_of(3) {
            0
        } else {
            (rng.next_u64() % 129) as u32
        };
        let a1 = (rng.next_u64() % (129 - n1 as u64)) as u32 % 128;
        let i2 = (rng.next_u64() % 128) as u32;
        let nb = (rng.next_u64() % (129 - i2 as u64)) as u32;
        let (o0, o1) = (cspace_counter(a0, i2, 0), cspace_counter(a1, i2, 0));
        let want = ArrayBus::new(&mut g).free_rows(o0, n0, o1, n1, nb, stride);
        blocked += (want < nb) as u32;
        let base = vme_map::GLOBAL_RAM_BASE;
        let (got, cycles) = b
            .call(
                &mut g,
                f,
                &[base + o0, n0, base + o1, n1, nb, stride],
                200_000,
            )
            .unwrap();
        assert_eq!(
            got, want,
            "case {case}: rows {i2}+{nb}, runs {a0}+{n0}, {a1}+{n1}"
        );
        assert!(cycles < 150_000, "{cycles} cycles");
    }
    assert!(
        blocked > 50 && blocked < 290,
        "{blocked} of 300 blocked: both outcomes tested"
    );
}

/// Counters the counting routines' tests add and subtract: all four, pairs, one.
const COUNTER_MASKS: [u32; 5] = [
    0x0101_0101,
    0x0100_0001,
    0x0001_0100,
    0x0000_0001,
    0x0101_0001,
];

/// Map column `i1` of global RAM `g` filled with random counter words: one in `one_in`
/// each of a word with a byte at 128, one with every byte at 127, one with two counters at
/// 1 and the others 0, and a zero word (the words the counting routines stop at or must
/// not), the rest plain words of equal counters 1-60.
fn random_counters(rng: &mut sim_host::sim::Rng, g: &mut [u8], i1: u32, one_in: u64) {
    use vme_map::layout::cspace_counter;
    for r in 0..128 {
        let v = match rng.next_u64() % one_in {
            0 => 0x0080_0000,
            1 => 0x7F7F_7F7F,
            2 => 0x0100_0001,
            3 => 0,
            _ => 0x0101_0101 * (1 + (rng.next_u64() % 60) as u32),
        };
        ArrayBus::new(g).write_u32(cspace_counter(i1, r, 0), v);
    }
}

/// The C-space board's column routine (`__vme_count_column`, the runtime's assembly) against
/// the host bus's loop: random columns with bytes near 0 and 128 scattered in, five random
/// runs from a random row (wrapping past the map's last row), a random number of pixels
/// passed over, drawing and erasing: the index it stops at and global RAM.
#[test]
fn count_column_matches_the_host_bus() {
    use vme_map::layout::{cspace_counter, CSPACE_MAP};
    let (mut b, img, mut g) = board_of(BoardId::Cspace0);
    let f = img
        .symbol("__vme_count_column")
        .expect("__vme_count_column in the cspace image");
    let mut rng = sim_host::sim::Rng::new(23);
    let pieces_at = 0x000C_0100u32; // board RAM for the five (rows, mask) pairs
    for case in 0..400u32 {
        let i1 = (rng.next_u64() % 128) as u32;
        random_counters(&mut rng, &mut g, i1, 24);
        let mut pieces = [0u32; 10];
        let mut left = 1 + (rng.next_u64() % 128) as u32;
        for p in 0..5 {
            let n = if p == 4 {
                left
            } else {
                (rng.next_u64() % (left as u64 + 1)) as u32
            };
            pieces[2 * p] = n;
            pieces[2 * p + 1] = COUNTER_MASKS[(rng.next_u64() % 5) as usize];
            left -= n;
        }
        let total: u32 = (0..5).map(|p| pieces[2 * p]).sum();
        let row = (rng.next_u64() % 128) as u32;
        let skip = (rng.next_u64() % (total as u64 + 1)) as u32 * (case % 2);
        let down = case % 3 == 0;
        for (k, w) in pieces.iter().enumerate() {
            put_word(&mut b.ram, pieces_at + 4 * k as u32, *w);
        }
        let col = cspace_counter(i1, 0, 0);
        assert_eq!(col, CSPACE_MAP + 4 * i1);
        let mut host = g.clone();
        let want = ArrayBus::new(&mut host).count_column(col, row, &pieces, skip, down);
        let (got, _) = b
            .call(
                &mut g,
                f,
                &[
                    vme_map::GLOBAL_RAM_BASE + col,
                    row,
                    pieces_at,
                    skip,
                    down as u32,
                ],
                200_000,
            )
            .unwrap();
        assert_eq!(got, want, "case {case}: where it stopped");
        assert!(g == host, "case {case}: global RAM differs");
    }
}

/// The C-space board's run routine (`__vme_count_run`, the runtime's assembly) against the
/// host bus's loop: random columns with bytes near 0 and 128 scattered in, a run of random
/// length (0 to the whole column) from a random row given unwrapped (past the map's last
/// row and past 128), each mask, drawing and erasing: the count it returns and global RAM.
#[test]
fn count_run_matches_the_host_bus() {
    use vme_map::layout::cspace_counter;
    let (mut b, img, mut g) = board_of(BoardId::Cspace0);
    let f = img
        .symbol("__vme_count_run")
        .expect("__vme_count_run in the cspace image");
    let mut rng = sim_host::sim::Rng::new(29);
    let (mut stopped, mut whole) = (0, 0);
    for case in 0..600u32 {
        let i1 = (rng.next_u64() % 128) as u32;
        // Mostly plain words, so that long runs go through; a few that stop a run.
        random_counters(&mut rng, &mut g, i1, 64);
        let rows = match case % 4 {
            0 => 1,
            1 => 1 + (rng.next_u64() % 4) as u32,
            2 => (rng.next_u64() % 129) as u32,
            _ => 128,
        };
        let row = (rng.next_u64() % 512) as u32;
        let mask = COUNTER_MASKS[(rng.next_u64() % 5) as usize];
        let down = case % 3 == 0;
        let col = cspace_counter(i1, 0, 0);
        let mut host = g.clone();
        let want = ArrayBus::new(&mut host).count_run(col, row, rows, mask, down);
        let (got, _) = b
            .call(
                &mut g,
                f,
                &[vme_map::GLOBAL_RAM_BASE + col, row, rows, mask, down as u32],
                200_000,
            )
            .unwrap();
        assert_eq!(
            got, want,
            "case {case}: rows {rows} from {row}, down {down}"
        );
        assert!(g == host, "case {case}: global RAM differs");
        if want < rows {
            stopped += 1;
        } else if rows > 1 {
            whole += 1;
        }
    }
    assert!(
        stopped > 50 && whole > 50,
        "{stopped} runs stopped, {whole} longer ones whole: both outcomes tested"
    );
}

/// The sensing board's filter (`__sense_filter`, the runtime's assembly: push a sample, then
/// the estimate) against `Filter::push` and `Filter::estimate` on the host: random walks
/// with jumps (the movement check and the long window's restart), the adaptive filter on
/// and off, resets, both windows filling and full; the estimate and every byte of the
/// filter after each sample.
#[test]
fn the_sensing_filter_matches_the_host_bit_for_bit() {
    use sensing::filter::{layout, Estimate, Filter, RECIP_Q16};
    let (mut b, img, mut g) = board_of(BoardId::Sensing);
    let f = img
        .symbol("__sense_filter")
        .expect("__sense_filter in the sensing image");
    // The reciprocal table the board passes, in board RAM.
    let table_at = BUF + 0x1000;
    for (n, v) in RECIP_Q16.iter().enumerate() {
        put_word(&mut b.ram, table_at + 4 * n as u32, *v as u32);
    }
    let (fa, ea) = (BUF as usize, BUF as usize + 0x800);
    let mut host = Filter::new();
    b.ram[fa..fa + layout::FILTER_BYTES].copy_from_slice(&host.to_be_bytes());
    let mut rng = sim_host::sim::Rng::new(31);
    let mut p = [0i32; 2];
    let mut v = [0i32; 2];
    let mut adaptive = true;
    let (mut estimates, mut full_long, mut moves) = (0, 0, 0);
    for step in 0..30_000u32 {
        match rng.next_u64() % 3000 {
            0 => {
                host.reset();
                b.ram[fa..fa + layout::FILTER_BYTES].copy_from_slice(&host.to_be_bytes());
            }
            1..=3 => p = [(rng.next_u64() % 16000) as i32 - 8000; 2],
            // Ramps from slow creep (below the movement threshold) to fast.
            4..=8 => {
                v = [
                    (rng.next_u64() % 41) as i32 - 20,
                    (rng.next_u64() % 9) as i32 - 4,
                ]
            }
            9..=14 => v = [0; 2],
            15 => adaptive = !adaptive,
            _ => {}
        }
        p = [
            (p[0] + v[0]).clamp(-8000, 8000),
            (p[1] + v[1]).clamp(-8000, 8000),
        ];
        let noise = |r: &mut sim_host::sim::Rng| (r.next_u64() % 61) as i32 - 30;
        let q = [p[0] + noise(&mut rng), p[1] + noise(&mut rng)];
        host.push(q, adaptive);
        let want = host.estimate(adaptive);
        b.ram[ea..ea + layout::ESTIMATE_BYTES].fill(0xEE);
        let (got, _) = b
            .call(
                &mut g,
                f,
                &[
                    fa as u32,
                    q[0] as u32,
                    q[1] as u32,
                    adaptive as u32,
                    ea as u32,
                    table_at,
                ],
                5_000,
            )
            .unwrap();
        let word = |o: usize| i32::from_be_bytes(b.ram[ea + o..ea + o + 4].try_into().unwrap());
        let got = (got != 0).then(|| Estimate {
            q5: [word(0), word(4)],
            samples: u16::from_be_bytes([b.ram[ea + 8], b.ram[ea + 9]]),
            moving: b.ram[ea + 10] != 0,
            filling: b.ram[ea + 11] != 0,
        });
        if let Some(e) = got {
            assert!(
                b.ram[ea + 10] <= 1 && b.ram[ea + 11] <= 1,
                "bools are 0 or 1"
            );
            estimates += 1;
            full_long += (e.samples == 255) as u32;
            moves += (e.moving && e.samples == 32) as u32;
        } else {
            assert_eq!(b.ram[ea], 0xEE, "step {step}: no estimate leaves out alone");
        }
        assert_eq!(got, want, "step {step}: the estimate");
        assert!(
            b.ram[fa..fa + layout::FILTER_BYTES] == host.to_be_bytes()[..],
            "step {step}: the filter's state"
        );
    }
    // The cases were all met: estimates, the long window full, movement.
    assert!(estimates > 25_000, "{estimates} estimates");
    assert!(full_long > 2_000, "{full_long} full long windows");
    assert!(moves > 400, "{moves} moving estimates");
}

/// The servo image's per-link routines (`__servo_observe`: the observer update and the
/// arrest point; `__servo_control`: the proximate law, near-goal corrections, notch, DAC
/// code and inertia estimate; the bodies of the two-link routines `Servo::step` calls, in
/// the runtime's assembly) against `LinkState::observe` and `LinkState::control` on the
/// host, both links, with the 3 kHz and the 750 Hz
/// constants: a closed loop on a rigid link with random goal jumps, timer jitter (periods
/// beyond the 10 ms bound too), encoder glitches (the observer's re-lock), the observers
/// settled or not, and random extreme errors and speeds (saturation on every path). The
/// results and every byte of the state after each call must be identical.
#[test]
fn the_servo_link_routines_match_the_host_bit_for_bit() {
    use servo::fx::host_mul_shr;
    use servo::{layout, params, LinkState, Observer, Regime};
    let (mut b, img, mut g) = board_of(BoardId::Servo);
    let fo = img
        .symbol("__servo_observe")
        .expect("__servo_observe in the image");
    let fc = img
        .symbol("__servo_control")
        .expect("__servo_control in the image");
    let (ka, oa, sa) = (BUF as usize, BUF as usize + 0x200, BUF as usize + 0x400);
    let mut rng = sim_host::sim::Rng::new(43);
    let mut rnd = |n: u64| (rng.next_u64() % n) as i64;
    let (mut regimes, mut relocks, mut estimates, mut deadband) = ([0u32; 3], 0, 0, 0);
    for set in [&params::TUNED, &params::TUNED_AT_IMAGE_HZ] {
        for (li, k) in set.iter().enumerate() {
            let link = [arm::LINK1, arm::LINK2][li];
            b.ram[ka..ka + layout::LINK_CONST_BYTES].copy_from_slice(&layout::link_const_be(k));
            let mut obs = Observer::at(0);
            let mut st = LinkState::new(k);
            let rad_per_count = std::f64::consts::TAU / link.counts_per_rev as f64;
            let (mut theta, mut omega, mut goal) = (0.0f64, 0.0f64, 0i32);
            for step in 0..12_000 {
                let ticks: i32 = match rnd(400) {
                    0 => 30_000 + rnd(35_000) as i32,
                    1 => 0,
                    _ => 600 + rnd(2100) as i32,
                };
                let dt_q32 = host_mul_shr(ticks, params::TIMER_TICK_Q40, 8);
                let dt = ticks as f64 / 2e6;
                // The rigid link under the last torque, with Coulomb friction.
                let u = st.torque_q16 as f64 / 65536.0;
                let fr = if omega.abs() > 1e-4 {
                    link.coulomb_nm * omega.signum()
                } else if u.abs() <= link.coulomb_nm {
                    u
                } else {
                    link.coulomb_nm * u.signum()
                };
                omega += (u - fr) / link.inertia_kgm2 * dt;
                theta += omega * dt;
                let c = (theta / rad_per_count).floor() as i32;
                let mut y = host_mul_shr(2 * c + 1, k.rad_per_count_q32, 17);
                match rnd(700) {
                    0 => y = y.wrapping_add(rnd(1 << 24) as i32 - (1 << 23)),
                    // At the edge of the plausible innovation, either side.
                    1..=3 => {
                        let bound =
                            host_mul_shr(k.omega_limit_q16, dt_q32.min(servo::MAX_DT_Q32), 32)
                                + servo::MAX_INNOVATION_Q16;
                        let side = if rnd(2) == 0 { 1 } else { -1 };
                        y = obs.theta_q16() + side * (bound + rnd(3) as i32 - 1);
                    }
                    _ => {}
                }
                if rnd(600) == 0 {
                    goal = rnd(8 << 16) as i32 - (4 << 16);
                }
                // Observe.
                b.ram[oa..oa + 8].copy_from_slice(&layout::observer_be(&obs));
                b.ram[sa..sa + layout::LINK_STATE_BYTES]
                    .copy_from_slice(&layout::link_state_be(&st));
                let before = obs;
                let want = st.observe(k, &mut obs, y, dt_q32);
                relocks += (obs.omega_q16 == 0 && before.omega_q16 != 0) as u32;
                let args = [ka as u32, oa as u32, sa as u32, y as u32, dt_q32 as u32];
                let (got, _) = b.call(&mut g, fo, &args, 20_000).unwrap();
                assert_eq!(got as i32, want, "link {li} step {step}: the arrest point");
                assert_eq!(
                    b.ram[sa..sa + layout::LINK_STATE_BYTES],
                    layout::link_state_be(&st),
                    "link {li} step {step}: the observer leaves the link's state alone"
                );
                assert_eq!(
                    b.ram[oa..oa + 8],
                    layout::observer_be(&obs),
                    "link {li} step {step}: the observer"
                );
                // Control: the loop's error and speed, or extremes now and then.
                let (err, w) = match rnd(50) {
                    0 => (
                        (rnd(1 << 32) as u32 as i32) >> rnd(8),
                        (rnd(1 << 32) as u32 as i32) >> (4 + rnd(8)),
                    ),
                    1 => (rnd(200) as i32 - 100, rnd(200) as i32 - 100),
                    _ => (y - goal, obs.omega_q16),
                };
                let settled = rnd(20) != 0;
                b.ram[sa..sa + layout::LINK_STATE_BYTES]
                    .copy_from_slice(&layout::link_state_be(&st));
                let inertia = st.est.inertia_q32;
                let (code, r) = st.control(k, err, w, dt_q32, settled);
                let args = [
                    ka as u32,
                    sa as u32,
                    err as u32,
                    w as u32,
                    dt_q32 as u32,
                    settled as u32,
                ];
                let (got, _) = b.call(&mut g, fc, &args, 50_000).unwrap();
                assert_eq!(
                    (got as u16 as i16, got >> 16),
                    (code, r as u32),
                    "link {li} step {step}: code and regime"
                );
                assert_eq!(
                    b.ram[sa..sa + layout::LINK_STATE_BYTES],
                    layout::link_state_be(&st),
                    "link {li} step {step}: the link's state"
                );
                regimes[r as usize] += 1;
                estimates += (st.est.inertia_q32 != inertia) as u32;
                deadband += (r == Regime::Linear && w.abs() < k.moving_q16) as u32;
            }
        }
    }
    // Every path was taken.
    assert!(regimes.iter().all(|&n| n > 1000), "regimes {regimes:?}");
    assert!(relocks > 20, "{relocks} re-locks");
    assert!(estimates > 20, "{estimates} inertia estimates accepted");
    assert!(deadband > 1000, "{deadband} passes at rest near the goal");
}

/// The sensing board's calibrated position (`__sense_locate`, the runtime's assembly: drift
/// correction, the inverse grid's bilinear blend, the calibrated area's test) against
/// `sensing::locate_um` on the host: random grids (nodes over the whole +-`MAX_NODE_UM`
/// range, so differences reach 2^21), signals beyond both ends of the grid (the clamps),
/// random drift estimates within their bounds or none, random areas; the position and the
/// outside flag must be identical.
#[test]
fn the_sensing_position_lookup_matches_the_host_bit_for_bit() {
    use sensing::cal::CalWords;
    use sensing::drift::{Drift, MAX_GAIN_Q24, MAX_OFFSET_Q5};
    use vme_map::records::cal::{INV, INV_N, MAX_NODE_UM};
    /// The table's inverse grid alone (the lookup reads no other word).
    struct Inv(Vec<u32>);
    impl CalWords for Inv {
        fn word(&mut self, i: u32) -> u32 {
            self.0[(i - INV) as usize]
        }
    }
    let (mut b, img, mut g) = board_of(BoardId::Sensing);
    let f = img
        .symbol("__sense_locate")
        .expect("__sense_locate in the sensing image");
    let (inv_at, drift_at, area_at, out_at) = (BUF, BUF + 0x10000, BUF + 0x10100, BUF + 0x10200);
    let mut rng = sim_host::sim::Rng::new(47);
    let mut r = move |n: i64| (rng.next_u64() % (2 * n as u64 + 1)) as i64 - n;
    let words = (2 * INV_N * INV_N) as usize;
    let (mut outside, mut clamped, mut corrected, mut edges) = (0, 0, 0, 0);
    for table in 0..6 {
        // Smooth grids (a scale and an offset per axis) with noise, and pure noise.
        let smooth = table % 2 == 0;
        let mut inv = Inv(vec![0; words]);
        for k in 0..words {
            let v = if smooth {
                let (i, j) = ((k / 2) as i64 % INV_N as i64, (k / 2) as i64 / INV_N as i64);
                let c = if k % 2 == 0 { i } else { j };
                (c - 32) * 15_000 + r(3_000)
            } else {
                r(MAX_NODE_UM as i64)
            };
            inv.0[k] = v as i32 as u32;
            put_word(&mut b.ram, inv_at + 4 * k as u32, v as u32);
        }
        for _ in 0..3_000 {
            let span = if r(4) == 0 { 1 << 18 } else { 70_000 };
            let v = [r(span) as i32, r(span) as i32];
            let drift = Drift::with(
                [
                    r((MAX_OFFSET_Q5 << 8) as i64) as i32,
                    r((MAX_OFFSET_Q5 << 8) as i64) as i32,
                ],
                [r(MAX_GAIN_Q24 as i64) as i32, r(MAX_GAIN_Q24 as i64) as i32],
                1,
            );
            let correct = (r(1) == 0) as u32;
            let mut area = [
                r(400_000) as i32 - 300_000,
                r(400_000) as i32 + 300_000,
                r(400_000) as i32 - 300_000,
                r(400_000) as i32 + 300_000,
            ];
            if r(1) == 0 {
                // One side within a micrometre of its margin's edge.
                let (p, _) = sensing::locate_um(&mut inv, v, &drift, correct, &area);
                let m = sensing::AREA_MARGIN_UM;
                let side = (r(2) + 2) as usize % 4;
                let d = r(1) as i32;
                area[side] = match side {
                    0 => p[0] + m + d,
                    1 => p[0] - m + d,
                    2 => p[1] + m + d,
                    _ => p[1] - m + d,
                };
                edges += 1;
            }
            let want = sensing::locate_um(&mut inv, v, &drift, correct, &area);
            // The fields the routine reads: the offsets and the correction's factors.
            use sensing::drift::layout::{K_Q14, O_Q13};
            for (at, words) in [(O_Q13, drift.o_q13), (K_Q14, drift.k_q14)] {
                for (n, w) in words.iter().enumerate() {
                    put_word(&mut b.ram, drift_at + (at + 4 * n) as u32, *w as u32);
                }
            }
            for (n, w) in area.iter().enumerate() {
                put_word(&mut b.ram, area_at + 4 * n as u32, *w as u32);
            }
            let (got, _) = b
                .call(
                    &mut g,
                    f,
                    &[
                        inv_at,
                        v[0] as u32,
                        v[1] as u32,
                        if correct != 0 { drift_at } else { 0 },
                        area_at,
                        out_at,
                    ],
                    5_000,
                )
                .unwrap();
            let word = |o: u32| {
                i32::from_be_bytes(b.ram[(out_at + o) as usize..][..4].try_into().unwrap())
            };
            assert_eq!(
                ([word(0), word(4)], got),
                want,
                "table {table}, signals {v:?}, drift {drift:?} ({correct}), area {area:?}"
            );
            outside += want.1;
            clamped += v.iter().any(|&s| s.abs() > 1 << 16) as u32;
            corrected += correct;
        }
    }
    // The cases were all met: outside and inside, clamped signals, with and without drift.
    assert!((2_000..16_000).contains(&outside), "{outside} outside");
    assert!(clamped > 2_000, "{clamped} clamped");
    assert!(corrected > 5_000, "{corrected} corrected");
    assert!(edges > 5_000, "{edges} at an edge");
}

/// The sensing board's LED current feedback (`__sense_feedback`, the runtime's assembly)
/// against `sensing::feedback_ma` on the host: drive levels and reference sums over their
/// ranges, sums from the occlusion threshold to full scale, and the edges (sums of 0 and
/// below, quotients at and beyond both clamps).
#[test]
fn the_sensing_feedback_matches_the_host_bit_for_bit() {
    let mut f = any_routine("__sense_feedback");
    let mut rng = sim_host::sim::Rng::new(53);
    let mut r = move |lo: i32, hi: i32| lo + (rng.next_u64() % (hi - lo + 1) as u64) as i32;
    let (mut low, mut high, mut between) = (0, 0, 0);
    for n in 0..20_000 {
        let level = r(0, 1023);
        let s_ref = r(0, 2047);
        let sum = match n % 4 {
            0 => r(-2048, 0),
            1 => r(1, 40),
            _ => r(200, 2047),
        };
        let want = sensing::feedback_ma(level, sum, s_ref);
        assert_eq!(
            f(&[level, sum, s_ref]),
            want,
            "level {level}, sum {sum}, s_ref {s_ref}"
        );
        match want {
            50 => low += 1,
            1000 => high += 1,
            _ => between += 1,
        }
    }
    for (level, sum, s_ref) in [
        (1000, 1, 2047),
        (50, 2047, 0),
        (0, -2_000_000_000, 5),
        (1023, -1, 2047),
    ] {
        assert_eq!(
            f(&[level, sum, s_ref]),
            sensing::feedback_ma(level, sum, s_ref)
        );
    }
    assert!(
        low > 1_000 && high > 1_000 && between > 5_000,
        "{low} / {between} / {high}"
    );
}
