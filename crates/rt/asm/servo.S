/* The servo board's control pass of both links in 68020 assembly (crates/servo; thesis ch. III,
 * Appendix A; docs/servo.md "Fixed point on the 68020").
 *
 * Two routines, each bit-identical to the Rust it replaces on the image (the system tests in
 * tests/tests/firmware_functions.rs run their per-link bodies, __servo_observe and
 * __servo_control, against the host's code on random states, and the image's whole
 * Servo::step against the host's):
 * __servo_observe2 (per link: the angle from the count, servo::LinkState::observe, the
 * arrest point) and __servo_control2 (per link: servo::LinkState::control for the proximate
 * law: the law, near_goal, the notch, the DAC code, the inertia estimate). Servo::step
 * calls each once a pass.
 *
 * The compiled pass took some 18,000 cycles for both links, a third of it in 41 calls of
 * __fx_mul_shr with its variable shift; here every product is a MULS.L with the shift
 * fixed by a macro, and the state stays in registers.
 *
 * Also here: the fixed-shift multiplies __fx_mul_shrN that fx::mul_shr calls in every image.
 *
 * Structure offsets: servo::layout asserts the same numbers. */

    /* LinkConst */
    .equ K_RPC, 0
    .equ K_INV_I, 4
    .equ K_UMAX, 8
    .equ K_INV_2UHAT, 32
    .equ K_ILO, 36
    .equ K_IHI, 40
    .equ K_ADAPT, 44
    .equ K_B0, 48
    .equ K_A1, 52
    .equ K_A2, 56
    .equ K_FRIC, 60
    .equ K_DEADBAND, 64
    .equ K_MOVING, 68
    .equ K_NM_PER_DAC, 76
    .equ K_K1, 80
    .equ K_K2, 84
    .equ K_OMLIM, 88
    .equ K_UHAT, 96
    .equ K_B, 100
    .equ K_SLOPE, 104
    .equ K_CPER, 108
    .equ K_YLPER, 112
    .equ K_DAC_Q5, 128
    .equ K_SATARG, 132
    /* Observer */
    .equ O_THETA, 0
    .equ O_OMEGA, 4
    /* LinkState: InertiaEstimate, Notch, torque */
    .equ E_BRAKE, 0
    .equ E_TWOA, 4
    .equ E_INERTIA, 8
    .equ E_IMPULSE, 12
    .equ E_OMEGA0, 16
    .equ E_YL, 20
    .equ E_C, 24
    .equ E_ACTIVE, 28
    .equ N_X1, 32
    .equ N_X2, 36
    .equ N_Y1, 40
    .equ N_Y2, 44
    .equ S_TORQUE, 48
    /* sizes of LinkConst, Observer, LinkState */
    .equ LINK_CONST_BYTES, 140
    .equ OBSERVER_BYTES, 8
    .equ LINK_STATE_BYTES, 52
    /* servo::MAX_DT_Q32 (10 ms), regs::servo::DAC_MAX / DAC_MIN */
    .equ MAX_DT_Q32, 42949673
    /* servo::MAX_INNOVATION_Q16 (servo::layout asserts it) */
    .equ MAX_INNOVATION_Q16, 655
    .equ DAC_MAX, 2047
    .equ DAC_MIN, -2048
    .equ ONE_Q16, 65536

/* SATV r: right after an ADD or SUB into r, saturate r if it overflowed (V): to i32::MAX
 * when the wrapped result is negative (the true one positive), else to i32::MIN. Rust's
 * saturating_add / saturating_sub. */
.macro SATV r
    bvc.s   .Lsv\@
    bmi.s   .Lsp\@
    move.l  #0x80000000, \r
    bra.s   .Lsv\@
.Lsp\@:
    move.l  #0x7fffffff, \r
.Lsv\@:
.endm

/* SATABS r: r = |r|, i32::MIN giving i32::MAX (saturating_abs). */
.macro SATABS r
    tst.l   \r
    bpl.s   .Lab\@
    neg.l   \r
    bpl.s   .Lab\@
    move.l  #0x7fffffff, \r
.Lab\@:
.endm

/* SATASL8 r, t: r = r * 256 saturated (saturating_mul(256)); t scratch. */
.macro SATASL8 r, t
    move.l  \r, \t
    asl.l   #8, \r
    bvc.s   .Las\@
    move.l  #0x7fffffff, \r
    tst.l   \t
    bpl.s   .Las\@
    addq.l  #1, \r
.Las\@:
.endm

/* MULSHR a, b, sh, h, t: a = round(a * b / 2^sh) saturated to i32, fx::mul_shr with a
 * fixed shift (8, 16, 17, 24 or 32); b any data addressing mode, h a scratch data
 * register, t a scratch data or address register, z (optional) a scratch data register
 * for the rounding carry (MOVEQ and ADDX: faster than the branch without it). The 64-bit
 * product of MULS.L plus 2^(sh-1), its high word h, fits in 32 bits after the shift when h
 * lies in [-2^(sh-1), 2^(sh-1)) (sh < 32); otherwise the sign of h says which way it
 * saturates (that branch is out of line). The check per shift, the cheapest found on the
 * 68020: 16, h equal to its low word sign-extended (MOVE.W, EXT.L or MOVEA.W, CMP); 24,
 * the V flag of ASL.L shifting h into place (set when a bit unlike the sign leaves it; t
 * keeps h for the sign); 8 and 17, h + 2^(sh-1) below 2^sh unsigned. (28 was the notch's,
 * in Q28 until 2026-11-26: the notch is 16-bit now.) */
.macro MULSHR a, b, sh, h, t, z
    muls.l  \b, \h:\a
.if \sh == 32
    tst.l   \a
    bpl.s   .Lmr\@
    addq.l  #1, \h
.Lmr\@:
    move.l  \h, \a
.else
    add.l   #(1 << (\sh - 1)), \a
  .ifb \z
    bcc.s   .Lmr\@
    addq.l  #1, \h
.Lmr\@:
  .else
    moveq   #0, \z
    addx.l  \z, \h
  .endif
  .if \sh == 16
    MR_SEXTW_NE \h, \t
    bne     .Lms\@
    move.w  \h, \a
    swap    \a
  .elseif \sh == 24
    move.l  \h, \t
    asl.l   #8, \h
    bvs     .Lms\@
    rol.l   #8, \a
    move.b  \a, \h
    move.l  \h, \a
  .else
    move.l  \h, \t
    add.l   #(1 << (\sh - 1)), \t
    cmp.l   #(1 << \sh), \t
    bcc     .Lms\@
    .if \sh == 8
    lsr.l   #8, \a
    swap    \h
    clr.w   \h
    lsl.l   #8, \h
    or.l    \h, \a
    .elseif \sh == 17
    clr.w   \a
    swap    \a
    lsr.l   #1, \a
    lsl.l   #8, \h
    lsl.l   #7, \h
    or.l    \h, \a
    .else
    .error "MULSHR: unsupported shift"
    .endif
  .endif
.Lmd\@:
    .subsection 1
.Lms\@:
    move.l  #0x7fffffff, \a
  .if \sh == 24
    tst.l   \t                  /* h before the shift */
  .else
    tst.l   \h
  .endif
    bpl     .Lmd\@
    addq.l  #1, \a
    bra     .Lmd\@
    .subsection 0
.endif
.endm

/* MR_SEXTW_NE h, t: Z clear (NE) unless h equals its low word sign-extended; t scratch
 * (MOVEA.W sign-extends by itself into an address register). */
.macro MR_SEXTW_NE h, t
  .ifc \t,%a0
    movea.w \h, \t
    cmpa.l  \h, \t
  .else
    move.w  \h, \t
    ext.l   \t
    cmp.l   \h, \t
  .endif
.endm

/* i32 __fx_mul_shrN(i32 a, i32 b) for N = 8, 16, 17, 24, 28, 32: fx::mul_shr(a, b, N)
 * without the variable shift of __fx_mul_shr (fx::mul_shr calls these for those shifts). */
.macro MULSHR_FN sh
    .section .text.__fx_mul_shr\sh, "ax"
    .globl __fx_mul_shr\sh
__fx_mul_shr\sh:
    move.l  4(%sp), %d0
    MULSHR  %d0, 8(%sp), \sh, %d1, %a0
    rts
.endm
    MULSHR_FN 8
    MULSHR_FN 16
    MULSHR_FN 17
    MULSHR_FN 24
    MULSHR_FN 32

/* i32 __fx_mul_floor_shr24(i32 a, i32 b): floor(a * b / 2^24), the low 32 bits
 * (fx::mul_floor_shr24): the 64-bit product's bits 24-55. */
    .section .text.__fx_mul_floor_shr24, "ax"
    .globl __fx_mul_floor_shr24
__fx_mul_floor_shr24:
    move.l  4(%sp), %d0
    muls.l  8(%sp), %d1:%d0
    lsl.l   #8, %d1             /* the high word's low 24 bits up */
    rol.l   #8, %d0             /* the low word's top byte down */
    move.b  %d0, %d1
    move.l  %d1, %d0
    rts

/* ---- the reflex's axis arithmetic (crates/reflex/src/lib.rs, `prepare`; here beside the
 * MULSHR macro it uses) ----
 * void __reflex_prepare(u32 i, const ServoView *sv, const i32 prev[2], const i32 prev_u[2],
 *                       const i32 goal_u[2], const Margins *m, const PrepConst *c, Axis *out):
 * axis i's Axis, bit for bit `reflex::prepare_host` (the Rust asserts every offset used
 * here). The Rust's sign masks are branches on the N flag of the same wrapped difference
 * (BMI / BPL, never BLT: a - b that overflows decides as the Rust's (a - b) >> 31 does), its
 * absolute values a NEG (the same for every value). urad_to_u is fx::mul_floor_shr24 with
 * c->urad_to_u_q24 (MULS.L, the 64-bit product's bits 24-55).
 * ServoView: theta_urad[2] 0, omega_urad_s[2] 8, arrest_urad[2] 16. Margins: lat_q32 0,
 * base 4, own 8. PrepConst: urad_to_u_q24 0, rest_u_s 4, stop_us_per_u_s_q24[2] 8,
 * margin_u 16, arrest_slack_shift 20. Axis: theta 0, goal 4, adv 8, stop_us 12,
 * theta_urad 16, arrest_urad 20, prev_urad 24, omega_urad_s 28, then the spans (lo, hi)
 * base 32, core 40, own 48, rest 56. */
.macro U_OF_URAD r, h
    muls.l  (%a5), \h:\r
    lsl.l   #8, \h
    rol.l   #8, \r
    move.b  \r, \h              /* h = floor(r K / 2^24) */
.endm
    .section .text.__reflex_prepare, "ax"
    .globl __reflex_prepare
__reflex_prepare:
    movem.l %d2-%d7/%a2-%a5, -(%sp) /* 40 bytes: arguments from 44(%sp) */
    move.l  44(%sp), %d7
    lsl.l   #2, %d7                 /* i * 4 */
    movea.l 48(%sp), %a0            /* sv */
    movea.l 68(%sp), %a5            /* c */
    movea.l 72(%sp), %a4            /* out */
    /* w = |urad_to_u(omega)|, reach = mul_shr(w, lat_q32, 32) + 1, adv = 2 reach */
    move.l  8(%a0,%d7.l), %d0
    move.l  %d0, 28(%a4)            /* omega_urad_s */
    moveq   #31, %d5
    move.l  %d0, %d1
    asr.l   %d5, %d1
    move.l  %d1, %d5                /* back = omega >> 31 */
    U_OF_URAD %d0, %d2
    tst.l   %d2
    bpl.s   1f
    neg.l   %d2                     /* w */
1:  movea.l 64(%sp), %a1            /* m */
    move.l  %d2, %d0
    muls.l  (%a1), %d3:%d0          /* w lat_q32 */
    tst.l   %d0
    bpl.s   2f
    addq.l  #1, %d3                 /* rounded: + 2^31 */
2:  addq.l  #1, %d3                 /* reach */
    move.l  %d3, %d4
    add.l   %d4, %d4                /* adv */
    move.l  %d4, 8(%a4)
    /* theta and the arrest point in angle units */
    move.l  0(%a0,%d7.l), %d0
    move.l  %d0, 16(%a4)            /* theta_urad */
    U_OF_URAD %d0, %d6              /* theta */
    move.l  %d6, 0(%a4)
    move.l  16(%a0,%d7.l), %d0
    move.l  %d0, 20(%a4)            /* arrest_urad */
    U_OF_URAD %d0, %d1              /* arrest */
    movea.l 52(%sp), %a1
    move.l  0(%a1,%d7.l), 24(%a4)   /* prev_urad = prev[i] */
    movea.l 60(%sp), %a1
    move.l  0(%a1,%d7.l), 4(%a4)    /* goal = goal_u[i] */
    movea.l 56(%sp), %a1
    movea.l 0(%a1,%d7.l), %a2       /* g_prev = prev_u[i] */
    move.l  8(%a5,%d7.l), %d7       /* stop_us_per_u_s_q24[i] */
    /* stop_us = mul_shr(max(w, rest_u_s), stop, 24) */
    move.l  %d2, %d0
    sub.l   4(%a5), %d0
    bpl.s   3f
    move.l  4(%a5), %d0             /* w < rest: rest */
    bra.s   4f
3:  move.l  %d2, %d0
4:  MULSHR  %d0, %d7, 24, %d2, %a3
    move.l  %d0, 12(%a4)            /* stop_us */
    /* a_end = arrest + (adv + (|arrest - theta| >> shift)) signed as the speed */
    move.l  %d1, %d0
    sub.l   %d6, %d0
    bpl.s   5f
    neg.l   %d0
5:  move.l  20(%a5), %d7
    asr.l   %d7, %d0                /* slack */
    add.l   %d4, %d0                /* ahead */
    eor.l   %d5, %d0
    sub.l   %d5, %d0
    add.l   %d1, %d0                /* a_end */
    /* lo = min(theta, a_end) in d7, hi = max in d0 */
    move.l  %d6, %d7
    sub.l   %d0, %d7
    bmi.s   6f
    move.l  %d0, %d7                /* theta >= a_end: lo = a_end */
    move.l  %d6, %d0                /* hi = theta */
    bra.s   7f
6:  move.l  %d6, %d7                /* lo = theta, hi = a_end */
7:  move.l  16(%a5), %d2            /* margin */
    move.l  %d7, %d4
    sub.l   %d2, %d4
    asr.l   #8, %d4
    move.l  %d4, 40(%a4)            /* core.lo */
    move.l  %d0, %d4
    add.l   %d2, %d4
    asr.l   #8, %d4
    move.l  %d4, 44(%a4)            /* core.hi */
    movea.l %d7, %a0                /* lo (sv no longer needed) */
    movea.l %d0, %a3                /* hi */
    /* glo = min(theta, g_prev) in d2, ghi = max in d4 */
    move.l  %a2, %d4
    move.l  %d6, %d2
    sub.l   %d4, %d2
    bmi.s   8f
    move.l  %d4, %d2                /* theta >= g: glo = g */
    move.l  %d6, %d4                /* ghi = theta */
    bra.s   9f
8:  move.l  %d6, %d2                /* glo = theta, ghi = g */
9:  /* outside: arrest < glo - tol or ghi + tol < arrest (tol = margin >> 1) */
    move.l  16(%a5), %d0
    asr.l   #1, %d0                 /* tol */
    move.l  %d1, %d7
    sub.l   %d2, %d7
    add.l   %d0, %d7                /* arrest - (glo - tol) */
    add.l   %d4, %d0
    sub.l   %d1, %d0                /* (ghi + tol) - arrest */
    or.l    %d0, %d7
    bmi.s   10f
    move.l  %d1, %d0                /* inside: the arrest point both ways */
    move.l  %d1, %d7
    bra.s   11f
10: move.l  %a0, %d0                /* outside: lo, hi */
    move.l  %a3, %d7
11: move.l  %d2, %d1                /* blo = min(glo, d0) in d2 */
    sub.l   %d0, %d1
    bmi.s   12f
    move.l  %d0, %d2
12: move.l  %d4, %d1                /* bhi = max(ghi, d7) in d4 */
    sub.l   %d7, %d1
    bpl.s   13f
    move.l  %d7, %d4
13: movea.l 64(%sp), %a1            /* m */
    move.l  4(%a1), %d1             /* base margin */
    move.l  %d2, %d0
    sub.l   %d1, %d0
    asr.l   #8, %d0
    move.l  %d0, 32(%a4)            /* base.lo */
    move.l  %d4, %d0
    add.l   %d1, %d0
    asr.l   #8, %d0
    move.l  %d0, 36(%a4)            /* base.hi */
    move.l  %d6, %d0
    sub.l   %d1, %d0
    asr.l   #8, %d0
    move.l  %d0, 56(%a4)            /* rest.lo */
    move.l  %d6, %d0
    add.l   %d1, %d0
    asr.l   #8, %d0
    move.l  %d0, 60(%a4)            /* rest.hi */
    move.l  8(%a1), %d1             /* own margin */
    move.l  %d5, %d0
    and.l   %d3, %d0                /* bwd = reach & back */
    move.l  %d6, %d2
    sub.l   %d0, %d2
    sub.l   %d1, %d2
    asr.l   #8, %d2
    move.l  %d2, 48(%a4)            /* own.lo */
    move.l  %d5, %d0
    not.l   %d0
    and.l   %d3, %d0                /* fwd = reach & !back */
    move.l  %d6, %d2
    add.l   %d0, %d2
    add.l   %d1, %d2
    asr.l   #8, %d2
    move.l  %d2, 52(%a4)            /* own.hi */
    movem.l (%sp)+, %d2-%d7/%a2-%a5
    rts

/* AGE d, now, since: d = min(now - since, 2^30) unsigned, the Rust's age of a timer
 * (`now.wrapping_sub(since).min(1 << 30)`); now and since any addressing modes. */
.macro AGE d, now, since
    move.l  \now, \d
    sub.l   \since, \d
    cmpi.l  #0x40000000, \d
    bls.s   .Lage\@
    move.l  #0x40000000, \d
.Lage\@:
.endm

/* u32 __reflex_stall(const ServoView *sv, const i32 goal[2], const i32 sub[2],
 *                    StallClock *clk, u32 now_us, const StallConst *c):
 * reflex::stall_flags, bit for bit `stall_flags_host` (crates/reflex/src/lib.rs asserts the
 * offsets): the at-goal, arrived and stalled flags, and the stall clock restarted (ref =
 * sub, since = now) when the subgoal moved, reached the goal or the arm moves. Each of the
 * Rust's sign masks is the sign of the same wrapped difference here, ORed before one
 * branch. StallClock: ref_urad[2] 0, since_us 8. StallConst: quarter_urad 0, rest_urad_s 4,
 * at_goal_urad 8, stall_us 12, the flags AT_GOAL 16, ARRIVED 20, STALLED 24. */
    .section .text.__reflex_stall, "ax"
    .globl __reflex_stall
__reflex_stall:
    movem.l %d2-%d5/%a2-%a4, -(%sp) /* 28 bytes: arguments from 32(%sp) */
    movea.l 32(%sp), %a0            /* sv */
    movea.l 36(%sp), %a1            /* goal */
    movea.l 40(%sp), %a2            /* sub */
    movea.l 44(%sp), %a3            /* clk */
    movea.l 52(%sp), %a4            /* c */
    /* off the goal: (sub - goal) | (goal - sub) of both, sign in d2 */
    move.l  (%a2), %d2
    sub.l   (%a1), %d2
    move.l  (%a1), %d0
    sub.l   (%a2), %d0
    or.l    %d0, %d2
    move.l  4(%a2), %d0
    sub.l   4(%a1), %d0
    or.l    %d0, %d2
    move.l  4(%a1), %d0
    sub.l   4(%a2), %d0
    or.l    %d0, %d2
    /* moving: rest - 1 - |omega| < 0 on either link, sign in d3 */
    move.l  4(%a4), %d1
    subq.l  #1, %d1
    move.l  8(%a0), %d0
    tst.l   %d0                     /* (the image check wants a test before a branch) */
    bpl.s   1f
    neg.l   %d0
1:  move.l  %d1, %d3
    sub.l   %d0, %d3
    move.l  12(%a0), %d0
    tst.l   %d0                     /* (the image check wants a test before a branch) */
    bpl.s   2f
    neg.l   %d0
2:  sub.l   %d0, %d1
    or.l    %d1, %d3
    /* far: at_goal_urad - |theta - goal| < 0 on either, sign in d4 */
    move.l  (%a0), %d0
    sub.l   (%a1), %d0
    bpl.s   3f
    neg.l   %d0
3:  move.l  8(%a4), %d4
    sub.l   %d0, %d4
    move.l  4(%a0), %d0
    sub.l   4(%a1), %d0
    bpl.s   4f
    neg.l   %d0
4:  move.l  8(%a4), %d1
    sub.l   %d0, %d1
    or.l    %d1, %d4
    /* moved: quarter - |sub - ref| < 0 on either, sign in d5 */
    move.l  (%a2), %d0
    sub.l   (%a3), %d0
    bpl.s   5f
    neg.l   %d0
5:  move.l  (%a4), %d5
    sub.l   %d0, %d5
    move.l  4(%a2), %d0
    sub.l   4(%a3), %d0
    bpl.s   6f
    neg.l   %d0
6:  move.l  (%a4), %d1
    sub.l   %d0, %d1
    or.l    %d1, %d5
    /* the flags */
    moveq   #0, %d0
    tst.l   %d2
    bmi.s   7f
    or.l    16(%a4), %d0            /* at the goal */
7:  move.l  %d3, %d1
    or.l    %d4, %d1
    bmi.s   8f
    or.l    20(%a4), %d0            /* arrived: neither moving nor far */
8:  move.l  %d2, %d1
    not.l   %d1                     /* at the goal */
    or.l    %d5, %d1                /* or moved */
    or.l    %d3, %d1                /* or moving: the clock restarts */
    bmi.s   10f
    AGE     %d1, 48(%sp), 8(%a3)    /* stuck for */
    move.l  12(%a4), %d2
    sub.l   %d1, %d2                /* stall_us - stuck_for */
    bpl.s   11f
    or.l    24(%a4), %d0            /* stalled */
    bra.s   11f
10: move.l  (%a2), (%a3)
    move.l  4(%a2), 4(%a3)
    move.l  48(%sp), 8(%a3)
11: movem.l (%sp)+, %d2-%d5/%a2-%a4
    rts

/* i32 __reflex_clamp_into(i32 goal_urad, i32 goal_u, i32 lo_px, i32 hi_px, i32 keep,
 *                         i32 u_to_urad_q16):
 * reflex::clamp_into, bit for bit `clamp_into_host`: the goal if it lies keep inside the
 * pixels lo_px ..= hi_px (256 angle units each), else the nearest point that does (the
 * middle if the span is too narrow), converted to urad (fx::mul_shr(u, q16, 16)). The
 * Rust's masks are the signs of the same wrapped differences, tested in its order. */
    .section .text.__reflex_clamp_into, "ax"
    .globl __reflex_clamp_into
__reflex_clamp_into:
    movem.l %d2-%d3, -(%sp)         /* 8 bytes: arguments from 12(%sp) */
    move.l  20(%sp), %d1
    lsl.l   #8, %d1
    add.l   28(%sp), %d1            /* lo = lo_px 256 + keep */
    move.l  24(%sp), %d2
    addq.l  #1, %d2
    lsl.l   #8, %d2
    subq.l  #1, %d2
    sub.l   28(%sp), %d2            /* hi = (hi_px + 1) 256 - 1 - keep */
    move.l  16(%sp), %d0            /* goal_u */
    move.l  %d2, %d3
    sub.l   %d1, %d3
    bmi.s   3f                      /* narrow: the middle */
    move.l  %d0, %d3
    sub.l   %d1, %d3
    bmi.s   1f                      /* below: lo */
    move.l  %d2, %d3
    sub.l   %d0, %d3
    bmi.s   2f                      /* above: hi */
    move.l  12(%sp), %d0            /* inside: the goal as it is */
    bra.s   9f
1:  move.l  %d1, %d0
    bra.s   4f
2:  move.l  %d2, %d0
    bra.s   4f
3:  move.l  20(%sp), %d0
    add.l   24(%sp), %d0
    addq.l  #1, %d0
    lsl.l   #8, %d0
    asr.l   #1, %d0                 /* (lo_px + hi_px + 1) 256 / 2 */
4:  MULSHR  %d0, 32(%sp), 16, %d1, %a0
9:  movem.l (%sp)+, %d2-%d3
    rts

/* i32 __reflex_health_entry(Monitor *m, u32 i, const EntryView *e, u32 now_us, i32 lag_um,
 *                           u32 torn_us, u32 lag_us):
 * reflex::health::Monitor::entry, bit for bit `entry_host` (crates/reflex/src/health.rs
 * asserts the offsets): entry i's claim and state kept, its claimed-since timer restarted
 * when it is free or changed, its lagging-since timer when it is not behind (undrawn, or
 * tracked more than lag_um off), its bits of the three verdicts (torn: claimed unchanged
 * beyond torn_us; lagging: behind beyond lag_us; behind now); returns -1 when it is
 * claimed and changed. EntryView: claim 0, state 4, lag_um 8, tracked 12 (byte), undrawn
 * 13 (byte). Monitor: claims[6] 28, states[6] 52, claimed_since_us[6] 76, lag_since_us[6]
 * 100, verdict[3] 136. Ages as the Rust's: now - since (wrapping), at most 2^30 unsigned. */
    .section .text.__reflex_health_entry, "ax"
    .globl __reflex_health_entry
__reflex_health_entry:
    movem.l %d2-%d5/%a2, -(%sp)     /* 20 bytes: arguments from 24(%sp) */
    movea.l 24(%sp), %a0            /* m */
    move.l  28(%sp), %d5            /* i */
    movea.l 32(%sp), %a1            /* e */
    move.l  36(%sp), %d4            /* now */
    move.l  %d5, %d0
    lsl.l   #2, %d0
    lea     0(%a0,%d0.l), %a2       /* entry i's words at 28, 52, 76, 100 from here */
    move.l  (%a1), %d2              /* claim */
    move.l  28(%a2), %d0
    eor.l   %d2, %d0
    move.l  4(%a1), %d1             /* state */
    move.l  52(%a2), %d3
    eor.l   %d1, %d3
    move.l  %d2, 28(%a2)
    move.l  %d1, 52(%a2)
    or.l    %d3, %d0
    sne     %d0
    extb.l  %d0                     /* changed */
    tst.l   %d2
    seq     %d1
    extb.l  %d1                     /* free */
    move.l  %d1, %d3
    or.l    %d0, %d3
    beq.s   1f
    move.l  %d4, 76(%a2)            /* free or changed: claimed since now */
1:  not.l   %d1
    and.l   %d1, %d0                /* returned: changed and claimed */
    moveq   #0, %d1                 /* behind */
    tst.b   13(%a1)
    bne.s   2f                      /* undrawn */
    tst.b   12(%a1)
    beq.s   3f                      /* not tracked */
    move.l  40(%sp), %d2
    sub.l   8(%a1), %d2            /* lag_um limit - lag */
    bpl.s   3f
2:  moveq   #-1, %d1
    bra.s   4f
3:  move.l  %d4, 100(%a2)           /* not behind: lagging since now */
4:  moveq   #1, %d2
    lsl.l   %d5, %d2                /* bit */
    move.l  %d2, %d3
    not.l   %d3
    and.l   %d2, %d1
    move.l  144(%a0), %d5
    and.l   %d3, %d5
    or.l    %d1, %d5
    move.l  %d5, 144(%a0)           /* behind now */
    AGE     %d1, %d4, 76(%a2)
    move.l  44(%sp), %d5
    sub.l   %d1, %d5
    smi     %d5
    extb.l  %d5
    and.l   %d2, %d5
    move.l  136(%a0), %d1
    and.l   %d3, %d1
    or.l    %d5, %d1
    move.l  %d1, 136(%a0)           /* torn */
    AGE     %d1, %d4, 100(%a2)
    move.l  48(%sp), %d5
    sub.l   %d1, %d5
    smi     %d5
    extb.l  %d5
    and.l   %d2, %d5
    move.l  140(%a0), %d1
    and.l   %d3, %d1
    or.l    %d5, %d1
    move.l  %d1, 140(%a0)           /* lagging */
    movem.l (%sp)+, %d2-%d5/%a2
    rts

/* u32 __reflex_health_observe(Monitor *m, const u32 hb[3], u32 frame, u32 torn, u32 fresh,
 *                             const EntryView *entries, u32 stride, u32 now_us,
 *                             const u32 lim[5]):
 * reflex::health::Monitor::observe after the first reading, bit for bit `observe_host`:
 * the heartbeats and the object table's frame taken (their timers and seen masks), each
 * entry with its bit in fresh read by __reflex_health_entry (entry i at entries + i stride),
 * the map's timer restarted by a heartbeat or an entry at work, and the code of what is
 * wrong (0 none, 1 stale map, 2 torn map, 3 lagging map, 4 stale positions). lim: lag (um),
 * torn, lag, map stale, positions stale (us). Monitor: hb[3] 0, hb_since_us 12, frame 16,
 * frame_had 20, frame_since_us 24, hb_seen 124, frame_seen 128, behind_now 132, verdict[3]
 * 136, seen 148. */
    .section .text.__reflex_health_observe, "ax"
    .globl __reflex_health_observe
__reflex_health_observe:
    movem.l %d2-%d7/%a2-%a4, -(%sp) /* 36 bytes: arguments from 40(%sp) */
    movea.l 40(%sp), %a2            /* m */
    movea.l 44(%sp), %a0            /* hb */
    move.l  68(%sp), %d7            /* now */
    movea.l 72(%sp), %a4            /* lim */
    /* beat: a heartbeat moved */
    move.l  (%a0), %d0
    move.l  (%a2), %d1
    eor.l   %d0, %d1
    move.l  %d0, (%a2)
    move.l  4(%a0), %d0
    move.l  4(%a2), %d2
    eor.l   %d0, %d2
    or.l    %d2, %d1
    move.l  %d0, 4(%a2)
    move.l  8(%a0), %d0
    move.l  8(%a2), %d2
    eor.l   %d0, %d2
    or.l    %d2, %d1
    move.l  %d0, 8(%a2)
    tst.l   %d1
    sne     %d6
    extb.l  %d6                     /* beat */
    or.l    %d6, 124(%a2)           /* hb_seen */
    /* the frame: a new one (read whole) restarts its timer */
    move.l  48(%sp), %d0            /* frame */
    tst.l   52(%sp)
    bne.s   2f                      /* torn: nothing taken */
    cmp.l   16(%a2), %d0
    beq.s   1f
    move.l  20(%a2), %d1
    or.l    %d1, 128(%a2)           /* frame_seen |= frame_had */
    move.l  %d7, 24(%a2)            /* frame_since = now */
1:  moveq   #-1, %d1
    move.l  %d1, 20(%a2)            /* frame_had */
    move.l  %d0, 16(%a2)            /* frame */
2:  /* the entries read this pass */
    move.l  56(%sp), %d5
    moveq   #63, %d0
    and.l   %d0, %d5
    or.l    %d5, 148(%a2)           /* seen */
    moveq   #0, %d4                 /* working */
    moveq   #0, %d2                 /* i */
    movea.l 60(%sp), %a3            /* &entries[0] */
3:  tst.l   %d5
    beq.s   5f
    btst    #0, %d5
    beq.s   4f
    move.l  8(%a4), -(%sp)          /* lag_us */
    move.l  4(%a4), -(%sp)          /* torn_us */
    move.l  (%a4), -(%sp)           /* lag_um */
    move.l  %d7, -(%sp)
    move.l  %a3, -(%sp)
    move.l  %d2, -(%sp)
    move.l  %a2, -(%sp)
    jsr     __reflex_health_entry
    lea     28(%sp), %sp
    or.l    %d0, %d4
4:  lsr.l   #1, %d5
    addq.l  #1, %d2
    adda.l  64(%sp), %a3            /* + stride */
    bra.s   3b
5:  or.l    %d4, %d6
    beq.s   6f
    move.l  %d7, 12(%a2)            /* a heartbeat or an entry at work: hb_since = now */
6:  tst.l   144(%a2)
    sne     %d0
    extb.l  %d0
    move.l  %d0, 132(%a2)           /* behind_now */
    /* the code, in order of precedence */
    moveq   #1, %d0
    tst.l   124(%a2)
    beq.s   9f                      /* no heartbeat seen: stale */
    AGE     %d1, %d7, 12(%a2)
    move.l  12(%a4), %d3
    sub.l   %d1, %d3
    bmi.s   9f                      /* stale */
    moveq   #2, %d0
    tst.l   136(%a2)
    bne.s   9f                      /* torn */
    moveq   #3, %d0
    tst.l   140(%a2)
    bne.s   9f                      /* lagging */
    moveq   #4, %d0
    tst.l   128(%a2)
    beq.s   9f                      /* no frame seen: stale positions */
    AGE     %d1, %d7, 24(%a2)
    move.l  16(%a4), %d3
    sub.l   %d1, %d3
    bmi.s   9f                      /* stale positions */
    moveq   #0, %d0
9:  movem.l (%sp)+, %d2-%d7/%a2-%a4
    rts

/* SQRT_Q16 x, r, t, u, s, a: x = fx::sqrt_q16(x), the square root of a non-negative Q16
 * value in Q16, 0 for x <= 0; r, t, u, s scratch data registers, a a scratch address
 * register. The input is shifted left by the largest even amount s <= 16 that keeps it in
 * 32 bits (BFFFO finds the leading zeros) to n, the integer root of n is taken and shifted
 * left by (16 - s) / 2. For n >= 2^30 the root is interpolated in a table of
 * T[i] = floor(2^19 sqrt(i)), the roots of i 2^22 in Q8 for i = 256..1024 (crates/rt/build.rs
 * writes it): with i = n >> 22 and f the next 16 bits of n, r = (T[i] + (T[i+1] - T[i]) f /
 * 2^16) >> 8. sqrt is concave and every step rounds down, so r <= floor(sqrt(n)); the chord
 * and the roundings lose less than one (at most 0.03, tested on the image's table), so r is
 * the floor or one less, and one MULU.W takes it up when (r + 1)^2 <= n (as r^2 + 2r < n,
 * which stays below 2^32). No divide (DIVU.L is 92 cycles on the 68020). For smaller n digit
 * by digit, 16 rounds of compare, subtract and shift. Bit-identical to host_sqrt_q16 in
 * crates/fx/src/lib.rs. */
.macro SQRT_Q16 x, r, t, u, s, a, zdone
  .ifb \zdone
    tst.l   \x
    ble     .Lqz\@
    bfffo   \x{#0:#32}, \s      /* leading zeros, 0..31 */
  .endif                        /* (zdone: the caller has x > 0 and s its leading zeros) */
    andi.l  #30, \s             /* even */
    cmpi.l  #16, \s
    bls.s   .Lq1\@
    moveq   #16, \s
.Lq1\@:
    lsl.l   \s, \x              /* n = x << s */
    cmpi.l  #0x40000000, \x
    bcs.s   .Lqd\@              /* n < 2^30 (x below 2^14): digit by digit */
    bfextu  \x{#0:#10}, \t      /* i = n >> 22, 256..1023 */
    lea     __fx_sqrt_table-1024, \a
    move.l  (\a,\t\().l*4), \r  /* T[i] */
    move.l  4(\a,\t\().l*4), \u /* T[i+1] */
    sub.l   \r, \u              /* below 2^14 */
    bfextu  \x{#10:#16}, \t     /* f */
    mulu.w  \t, \u
    clr.w   \u
    swap    \u
    add.l   \u, \r
    lsr.l   #8, \r              /* the floor of sqrt(n) or one less */
    move.l  \r, \t
    mulu.w  \t, \t
    add.l   \r, \t
    add.l   \r, \t              /* r^2 + 2r */
    sub.l   \x, \t              /* borrow (X) when below n */
    moveq   #0, \u
    addx.l  \u, \r              /* r + 1 when (r + 1)^2 <= n */
    bra.s   .Lqf\@
.Lqd\@:
    moveq   #0, \r              /* r */
    move.l  #0x40000000, \t     /* bit */
.Lq2\@:
    move.l  \r, \u
    add.l   \t, \u              /* r + bit */
    cmp.l   \u, \x
    bcs.s   .Lq3\@              /* n < r + bit (unsigned) */
    sub.l   \u, \x
    lsr.l   #1, \r
    add.l   \t, \r
    bra.s   .Lq4\@
.Lq3\@:
    lsr.l   #1, \r
.Lq4\@:
    lsr.l   #2, \t
    tst.l   \t
    bne.s   .Lq2\@
.Lqf\@:
    moveq   #16, \x
    sub.l   \s, \x
    lsr.l   #1, \x              /* (16 - s) / 2 */
    lsl.l   \x, \r
    move.l  \r, \x
    bra.s   .Lqe\@
.Lqz\@:
    moveq   #0, \x
.Lqe\@:
.endm

/* i32 __fx_sqrt_q16(i32 x): SQRT_Q16 as a function (fx::sqrt_q16 calls it in every image;
 * the servo's law takes it inline). */
    .section .text.__fx_sqrt_q16, "ax"
    .globl __fx_sqrt_q16
    .globl __fx_sqrt_table
__fx_sqrt_q16:
    movem.l %d2-%d4, -(%sp)     /* argument now at 16 */
    move.l  16(%sp), %d0
    SQRT_Q16 %d0, %d1, %d2, %d3, %d4, %a0
    movem.l (%sp)+, %d2-%d4
    rts
/* T[i] = floor(2^19 sqrt(i)) for i = 256..1024 (u32), written by crates/rt/build.rs; data,
 * not code (the image check reads .text as instructions). */
    .section .rodata.__fx_sqrt_table, "a"
    .even
__fx_sqrt_table:
    .include "sqrt_table.s"


/* CLAMP r, lim, t: r = clamp(r, -lim, lim) for lim >= 0 (any data mode); t scratch. */
.macro CLAMP r, lim, t
    move.l  \lim, \t
    cmp.l   \t, \r
    ble.s   .Lc1\@
    move.l  \t, \r
    bra.s   .Lc2\@
.Lc1\@:
    neg.l   \t
    cmp.l   \t, \r
    bge.s   .Lc2\@
    move.l  \t, \r
.Lc2\@:
.endm

/* ---- the observer update and arrest point of both links ----
 * void __servo_observe2(const LinkConst k[2], Observer o[2], const LinkState s[2],
 *                       const i32 counts[2], i32 dt_q32, i32 out[4]): both links, the
 *                       angle of each from its extended count first (the middle of the
 *                       count: mul_shr(2 count + 1, rad_per_count, 17)); out = the two
 *                       angles, then the two arrest points; per link
 *                       servo::LinkState::observe (the torque that acted and the
 *                       switching curve's brake come from s).
 * The bodies per link: servo_observe_body (a0 = k, a1 = o, a2 = s, d2 = y, d3 = dt; d0 =
 * the new speed, 0 after a re-lock; d1, d3-d7 clobbered), then servo_arrest_body (below;
 * __servo_pass calls it every other pass only). */
    .section .text.__servo_observe2, "ax"
    .globl __servo_observe2
__servo_observe2:
    movem.l %d2-%d7/%a2-%a3, -(%sp) /* arguments now at 36, 40, 44, 48, 52, 56 */
    movea.l 48(%sp), %a3        /* counts */
    movea.l 36(%sp), %a0        /* link 1 */
    bsr     servo_angle
    movea.l 56(%sp), %a1
    move.l  %d2, (%a1)
    movea.l 40(%sp), %a1
    movea.l 44(%sp), %a2
    move.l  52(%sp), %d3
    bsr     servo_observe_body
    bsr     servo_arrest_body
    movea.l 56(%sp), %a1
    move.l  %d0, 8(%a1)
    addq.l  #4, %a3             /* link 2 */
    movea.l 36(%sp), %a0
    lea     LINK_CONST_BYTES(%a0), %a0
    bsr     servo_angle
    movea.l 56(%sp), %a1
    move.l  %d2, 4(%a1)
    movea.l 40(%sp), %a1
    addq.l  #OBSERVER_BYTES, %a1
    movea.l 44(%sp), %a2
    lea     LINK_STATE_BYTES(%a2), %a2
    move.l  52(%sp), %d3
    bsr     servo_observe_body
    bsr     servo_arrest_body
    movea.l 56(%sp), %a1
    move.l  %d0, 12(%a1)
    movem.l (%sp)+, %d2-%d7/%a2-%a3
    rts

/* i32 __servo_observe(const LinkConst *k, Observer *o, const LinkState *s, i32 y_q16,
 * i32 dt_q32): one link's body alone (servo::LinkState::observe), for the tests that run it
 * against the host's on random states; in this section so that it stays linked with the
 * routine the board calls. */
    .globl __servo_observe
__servo_observe:
    movem.l %d2-%d7/%a2, -(%sp) /* arguments now at 32, 36, 40, 44, 48 */
    movea.l 32(%sp), %a0
    movea.l 36(%sp), %a1
    movea.l 40(%sp), %a2
    move.l  44(%sp), %d2
    move.l  48(%sp), %d3
    bsr     servo_observe_body
    bsr     servo_arrest_body
    movem.l (%sp)+, %d2-%d7/%a2
    rts

/* d2 = mul_shr(2 (a3) + 1, k->rad_per_count, 17) for a0 = k (wrapping 2 n + 1, as the
 * release build's); d1, d7 clobbered. */
servo_angle:
    move.l  (%a3), %d2
    add.l   %d2, %d2
    addq.l  #1, %d2
    MULSHR  %d2, K_RPC(%a0), 17, %d1, %d7, %d7
    rts

servo_observe_body:
    cmpi.l  #MAX_DT_Q32, %d3    /* dt = min(dt, MAX_DT) */
    ble     1f
    move.l  #MAX_DT_Q32, %d3
1:  /* e = sat(y * 256) - theta24, saturating (Q24) */
    move.l  %d2, %d4
    SATASL8 %d4, %d7
    sub.l   O_THETA(%a1), %d4
    SATV    %d4
    /* implausible when |e| > sat(sat(mul_shr(omega_limit, dt, 32) + 0.01 rad) * 256);
     * never when |e| <= 0.01 rad (Q24) with dt >= 0, the bound's least then (omega_limit
     * >= 0: servo::params asserts it), which is every pass of a locked observer: the
     * bound's product only beyond */
    move.l  %d4, %d1
    SATABS  %d1
    tst.l   %d3
    bmi.s   5f
    cmpi.l  #(MAX_INNOVATION_Q16 * 256), %d1
    ble.s   6f
5:  move.l  K_OMLIM(%a0), %d0
    MULSHR  %d0, %d3, 32, %d1, %d7, %d7
    addi.l  #MAX_INNOVATION_Q16, %d0
    SATV    %d0
    SATASL8 %d0, %d7
    move.l  %d4, %d1
    SATABS  %d1
    cmp.l   %d0, %d1
    bgt     9f
6:
    /* friction the law compensates: f the way the link turns; at rest clamp(u, -f, f) */
    move.l  O_OMEGA(%a1), %d5   /* omega */
    move.l  S_TORQUE(%a2), %d6  /* u: the torque that acted */
    move.l  K_FRIC(%a0), %d7
    move.l  K_MOVING(%a0), %d0
    cmp.l   %d0, %d5
    bgt     4f                  /* turning +: f */
    neg.l   %d0
    cmp.l   %d0, %d5
    blt     3f                  /* turning -: -f */
    cmp.l   %d7, %d6
    bgt     4f                  /* u > f: f */
    neg.l   %d7
    cmp.l   %d7, %d6
    blt     4f                  /* u < -f: -f */
    move.l  %d6, %d7            /* u */
    bra     4f
3:  neg.l   %d7
4:  sub.l   %d7, %d6            /* net = u - friction, saturating */
    SATV    %d6
    /* dtheta = sat(omega + mul_shr(k1, e, 24)); theta24 = sat(theta24 + mul_shr(dtheta, dt, 24)) */
    move.l  K_K1(%a0), %d0
    MULSHR  %d0, %d4, 24, %d1, %d7, %d7
    add.l   %d5, %d0
    SATV    %d0
    MULSHR  %d0, %d3, 24, %d1, %d7, %d7
    add.l   O_THETA(%a1), %d0
    SATV    %d0
    move.l  %d0, O_THETA(%a1)
    /* accel = sat(mul_shr(net, 1/I, 16) + mul_shr(k2, e, 16)) */
    move.l  K_INV_I(%a0), %d0
    MULSHR  %d0, %d6, 16, %d1, %d7, %d7
    move.l  %d0, %d6
    move.l  K_K2(%a0), %d0
    MULSHR  %d0, %d4, 16, %d1, %d7, %d7
    add.l   %d6, %d0
    SATV    %d0
    /* omega = clamp(sat(omega + mul_shr(accel, dt, 32)), -limit, limit) */
    MULSHR  %d0, %d3, 32, %d1, %d7, %d7
    add.l   %d5, %d0
    SATV    %d0
    CLAMP   %d0, K_OMLIM(%a0), %d1
    move.l  %d0, O_OMEGA(%a1)
    rts
9:  /* implausible: re-lock at rest on the measurement (theta24 = y << 8, wrapping) */
    move.l  %d2, %d0
    lsl.l   #8, %d0
    move.l  %d0, O_THETA(%a1)
    clr.l   O_OMEGA(%a1)
    moveq   #0, %d0
    rts

/* d0 = the arrest point sat(y + mul_shr(mul_shr(omega, brake, 24), |omega|, 24)) for
 * d0 = omega, d2 = y, a2 = s (its brake); d1, d5, d7 clobbered. (After a re-lock, omega 0:
 * y.) */
servo_arrest_body:
    move.l  %d0, %d5
    MULSHR  %d0, E_BRAKE(%a2), 24, %d1, %d7, %d7
    SATABS  %d5
    MULSHR  %d0, %d5, 24, %d1, %d7, %d7
    add.l   %d2, %d0
    SATV    %d0
    rts

/* ---- the law of both links ----
 * void __servo_control2(const LinkConst k[2], LinkState s[2], const i32 err[2],
 *                       const i32 omega[2], i32 dt_q32, u32 settled, u32 out[2]): both
 *                       links, out[i] = regime << 16 | DAC code (regime 0 saturated,
 *                       1 sliding, 2 linear); per link servo::LinkState::control for the
 *                       proximate law.
 * The body per link: a2 = k, a3 = s, d2 = err, d3 = omega, a4 = dt, a5 = settled;
 * d0 = regime << 16 | code; d1-d7, a0, a1 clobbered. */
    .section .text.__servo_control2, "ax"
    .globl __servo_control2
__servo_control2:
    movem.l %d2-%d7/%a2-%a5, -(%sp) /* arguments now at 44, 48, 52, 56, 60, 64, 68 */
    movea.l 44(%sp), %a2        /* link 1 */
    movea.l 48(%sp), %a3
    movea.l 52(%sp), %a0
    move.l  (%a0), %d2
    movea.l 56(%sp), %a0
    move.l  (%a0), %d3
    movea.l 60(%sp), %a4
    movea.l 64(%sp), %a5
    bsr     servo_control_body
    movea.l 68(%sp), %a0
    move.l  %d0, (%a0)
    movea.l 44(%sp), %a2        /* link 2 */
    lea     LINK_CONST_BYTES(%a2), %a2
    movea.l 48(%sp), %a3
    lea     LINK_STATE_BYTES(%a3), %a3
    movea.l 52(%sp), %a0
    move.l  4(%a0), %d2
    movea.l 56(%sp), %a0
    move.l  4(%a0), %d3
    bsr     servo_control_body
    movea.l 68(%sp), %a0
    move.l  %d0, 4(%a0)
    movem.l (%sp)+, %d2-%d7/%a2-%a5
    rts

/* u32 __servo_control(const LinkConst *k, LinkState *s, i32 err_q16, i32 omega_q16,
 * i32 dt_q32, u32 settled): one link's body alone (servo::LinkState::control), for the
 * tests; kept linked with __servo_control2 as __servo_observe is with __servo_observe2. */
    .globl __servo_control
__servo_control:
    movem.l %d2-%d7/%a2-%a5, -(%sp) /* arguments now at 44, 48, 52, 56, 60, 64 */
    movea.l 44(%sp), %a2
    movea.l 48(%sp), %a3
    move.l  52(%sp), %d2
    move.l  56(%sp), %d3
    movea.l 60(%sp), %a4
    movea.l 64(%sp), %a5
    bsr     servo_control_body
    movem.l (%sp)+, %d2-%d7/%a2-%a5
    rts

servo_control_body:
    /* the proximate law: f from the linear line or the offset braking curve */
    move.l  %d2, %d6
    SATABS  %d6                 /* d = |err| */
    moveq   #2, %d5             /* regime: linear */
    cmp.l   E_YL(%a3), %d6
    bgt     1f
    move.l  %d2, %d0
    MULSHR  %d0, K_SLOPE(%a2), 16, %d1, %d7, %d7
    neg.l   %d0                 /* f = -mul_shr(err, slope, 16) */
    bra     2f
1:  moveq   #1, %d5             /* sliding */
    move.l  E_TWOA(%a3), %d0
    MULSHR  %d0, %d6, 16, %d1, %d7, %d7
    /* The square root is at least L = 2^(k / 2 + 8) for x in [2^k, 2^(k+1)) (the floor
     * of sqrt(x 2^s), shifted, as SQRT_Q16 takes it), so f - omega is at most c - L - omega
     * (err > 0) or at least L - c - omega (err < 0): beyond sat_arg that way, the law
     * saturates whatever the root (servo::params::LinkConst::sat_arg_q16), and the root,
     * the product by b and the clamp are left out: most of an acceleration at full torque.
     * (An add that overflows takes the whole way.) */
    tst.l   %d0
    ble     25f
    bfffo   %d0{#0:#32}, %d7    /* z, kept for SQRT_Q16 */
    moveq   #31, %d1
    sub.l   %d7, %d1
    lsr.l   #1, %d1
    addq.l  #8, %d1
    moveq   #1, %d4
    lsl.l   %d1, %d4            /* L */
    sub.l   E_C(%a3), %d4       /* t = L - c */
    tst.l   %d2
    ble.s   24f
    add.l   %d3, %d4            /* err > 0: c - L - omega <= -sat_arg? */
    bvs.s   23f
    cmp.l   K_SATARG(%a2), %d4
    blt.s   23f
    move.l  K_UMAX(%a2), %d0
    neg.l   %d0                 /* -umax, saturated */
    moveq   #0, %d5
    bra     4f
24: sub.l   %d3, %d4            /* err < 0: L - c - omega >= sat_arg? */
    bvs.s   23f
    cmp.l   K_SATARG(%a2), %d4
    blt.s   23f
    move.l  K_UMAX(%a2), %d0    /* umax, saturated */
    moveq   #0, %d5
    bra     4f
25: moveq   #0, %d0             /* x <= 0: the root is 0 */
    bra.s   26f
23: SQRT_Q16 %d0, %d1, %d4, %d6, %d7, %a0, zdone
26: sub.l   E_C(%a3), %d0       /* v = sqrt(2A d) - c */
    tst.l   %d2
    ble     2f
    neg.l   %d0                 /* err > 0: f = -v */
2:  sub.l   %d3, %d0            /* f - omega, saturating */
    SATV    %d0
    MULSHR  %d0, K_B(%a2), 16, %d1, %d7, %d7
    move.l  K_UMAX(%a2), %d1    /* u = clamp(arg, -umax, umax); saturated if it moved */
    cmp.l   %d1, %d0
    ble     3f
    move.l  %d1, %d0
    moveq   #0, %d5
    bra     4f
3:  neg.l   %d1
    cmp.l   %d1, %d0
    bge     4f
    move.l  %d1, %d0
    moveq   #0, %d5
4:  move.l  %d0, %d4            /* u */
    /* near_goal */
    move.l  K_DEADBAND(%a2), %d6
    tst.l   %d6                 /* (MOVE sets Z too; the image check wants the test) */
    beq     8f                  /* no dead band: the law's torque as it is */
    move.l  K_MOVING(%a2), %d0
    cmp.l   %d0, %d3
    bgt     5f                  /* turning +: dir = 1 */
    neg.l   %d0
    cmp.l   %d0, %d3
    blt     6f                  /* turning -: dir = -1 */
    move.l  %d2, %d1            /* at rest */
    SATABS  %d1
    cmp.l   %d6, %d1
    bgt     7f
    move.l  %d3, %d0            /* within the dead band: damping only */
    MULSHR  %d0, K_B(%a2), 16, %d1, %d7, %d7
    neg.l   %d0
    move.l  %d0, %d4
    bra     8f
7:  /* dir = clamp(mul_shr(u, 10, 16), -1, 1): 10 u exactly (|u| <= umax, which
     * servo::params asserts below 2^31 / 10); at +-1 the friction itself (5, 6) */
    move.l  %d4, %d0
    move.l  %d4, %d1
    lsl.l   #3, %d0
    add.l   %d1, %d1
    add.l   %d1, %d0            /* 10 u */
    cmpi.l  #ONE_Q16, %d0
    bge     5f
    cmpi.l  #-ONE_Q16, %d0
    ble     6f
    bra     9f
5:  move.l  K_FRIC(%a2), %d0    /* dir = 1: mul_shr(friction, 1.0, 16) is friction */
    bra     20f
6:  move.l  K_FRIC(%a2), %d0    /* dir = -1: -friction (>= 0, so no overflow) */
    neg.l   %d0
    bra     20f
9:  MULSHR  %d0, K_FRIC(%a2), 16, %d1, %d7, %d7
20: add.l   %d4, %d0            /* clamp(sat(u + friction), -umax, umax) */
    SATV    %d0
    CLAMP   %d0, K_UMAX(%a2), %d1
    move.l  %d0, %d4
8:  /* the torque in Q11: x = (u + 16) >> 5 (|u| <= umax < 16 N m: an i16) */
    moveq   #16, %d0
    add.l   %d0, %d4
    asr.l   #5, %d4
    /* the notch: y = clamp((b0 (x + x2) + a1 (x1 - y1) - a2 y2 + 2^12) >> 13, +-32767),
     * coefficients Q13 and data Q11 within i16 (params asserts the sum below 2^31): the
     * sums of two by 32-bit MULS.L, y2 by MULS.W, no range checks */
    move.l  K_B0(%a2), %d0
    tst.l   %d0                 /* (MOVE sets Z too; the image check wants the test) */
    beq     10f
    move.l  %d4, %d6
    add.l   N_X2(%a3), %d6
    muls.l  %d0, %d6            /* b0 (x + x2) */
    move.l  N_X1(%a3), %d0
    sub.l   N_Y1(%a3), %d0
    muls.l  K_A1(%a2), %d0      /* a1 (x1 - y1) */
    add.l   %d0, %d6
    move.w  N_Y2+2(%a3), %d0
    muls.w  K_A2+2(%a2), %d0    /* a2 y2 */
    sub.l   %d0, %d6
    addi.l  #4096, %d6
    moveq   #13, %d0
    asr.l   %d0, %d6
    CLAMP   %d6, #32767, %d1
    move.l  N_X1(%a3), N_X2(%a3)
    move.l  %d4, N_X1(%a3)
    move.l  N_Y1(%a3), N_Y2(%a3)
    move.l  %d6, N_Y1(%a3)
    move.l  %d6, %d4
10: /* the DAC code: clamp((y dac_per_nm_q5 + 2^15) >> 16, DAC_MIN, DAC_MAX), y and the
     * constant within i16 */
    move.w  %d4, %d0
    muls.w  K_DAC_Q5+2(%a2), %d0
    addi.l  #32768, %d0
    swap    %d0
    ext.l   %d0
    cmpi.l  #DAC_MAX, %d0
    ble     11f
    move.l  #DAC_MAX, %d0
11: cmpi.l  #DAC_MIN, %d0
    bge     12f
    move.l  #DAC_MIN, %d0
12: move.l  %d0, %d6            /* code */
    move.l  %d0, %d4
    muls.w  K_NM_PER_DAC+2(%a2), %d4 /* the torque it makes: the code and nm_per_dac
                                 * (its low word; params asserts it fits) are i16 */
    /* full torque the way the link turns, once the observers are settled */
    cmpa.w  #0, %a5
    beq     14f
    tst.l   %d3
    beq     14f
    bmi     13f
    cmpi.l  #DAC_MAX, %d6
    bge     15f
    bra     14f
13: cmpi.l  #-DAC_MAX, %d6
    ble     15f
14: /* not accelerating (or no estimation): the estimate rests */
    clr.b   E_ACTIVE(%a3)
    bra     19f
15: tst.l   K_ADAPT(%a2)
    beq     14b
    tst.b   E_ACTIVE(%a3)
    bne     16f
    move.b  #1, E_ACTIVE(%a3)   /* a new acceleration: the impulse starts */
    clr.l   E_IMPULSE(%a3)
    move.l  %d3, E_OMEGA0(%a3)
    bra     19f
16: move.l  %a4, %d2            /* impulse += mul_shr(prev torque, min(dt, MAX_DT), 32) */
    cmpi.l  #MAX_DT_Q32, %d2
    ble     17f
    move.l  #MAX_DT_Q32, %d2
17: move.l  S_TORQUE(%a3), %d0
    MULSHR  %d0, %d2, 32, %d1, %d7, %d7
    add.l   %d0, E_IMPULSE(%a3)
    move.l  %d3, %d2            /* dw = omega - omega0 */
    sub.l   E_OMEGA0(%a3), %d2
    move.l  %d2, %d0
    tst.l   %d0
    bpl     18f
    neg.l   %d0
18: cmp.l   K_ADAPT(%a2), %d0
    blt     19f                 /* |dw| below the threshold: not yet */
    pea     31                  /* I = div_shl(2 impulse, dw, 31), Q32 */
    move.l  %d2, -(%sp)
    move.l  E_IMPULSE(%a3), %d0
    add.l   %d0, %d0
    move.l  %d0, -(%sp)
    jsr     __fx_div
    lea     12(%sp), %sp
    cmp.l   K_ILO(%a2), %d0
    blt     19f
    cmp.l   K_IHI(%a2), %d0
    bgt     19f
    move.l  %d0, E_INERTIA(%a3) /* plausible: the curve follows it */
    move.l  %d0, %d2
    MULSHR  %d0, K_INV_2UHAT(%a2), 24, %d1, %d7, %d7
    move.l  %d0, E_BRAKE(%a3)
    move.l  %d2, %d0
    asr.l   #2, %d0
    pea     31                  /* 2 u^ / I = div_shl(u^, I >> 2, 31), Q16 */
    move.l  %d0, -(%sp)
    move.l  K_UHAT(%a2), -(%sp)
    jsr     __fx_div
    lea     12(%sp), %sp
    move.l  %d0, E_TWOA(%a3)
    move.l  %d0, %d2
    MULSHR  %d0, K_YLPER(%a2), 32, %d1, %d7, %d7
    move.l  %d0, E_YL(%a3)
    move.l  %d2, %d0
    MULSHR  %d0, K_CPER(%a2), 32, %d1, %d7, %d7
    move.l  %d0, E_C(%a3)
19: move.l  %d4, S_TORQUE(%a3)
    move.l  %d5, %d0            /* regime << 16 | code */
    swap    %d0
    move.w  %d6, %d0
    rts

/* ---- the common pass of Servo::step ----
 * u32 __servo_pass(Servo *s, const u16 io[3], const i32 sub[3], Output *out): io = both
 * encoder latches and the timer, sub = the subgoal (both goals in urad, the reflex cycle).
 * servo::Servo::step for a pass after the first with a subgoal and the proximate law on
 * both links, following the subgoal or holding (out of range, stale) at a hold goal chosen
 * before: first, changing nothing, it checks those, the period and the subgoal's verdict;
 * a pass that is not that one (among them the first pass of a hold, whose goal comes from
 * the arrest log) returns 0, and the Rust then runs it. Otherwise, as the Rust does: the
 * extended counts, the period, the observers' settling clock, both links' angles and
 * observers, the log's clock and, every other pass (servo::Servo::log_arrest), the arrest
 * points and their log, the cycle's age, the hold and its fault, the goal, both links'
 * law; every field of out (servo::Output; the amplifiers enabled); returns 1.
 * Offsets: servo::layout asserts them. */
    /* Servo */
    .equ SV_LAST_ENC, 2
    .equ SV_COUNTS, 6
    .equ SV_LAST_TIMER, 14
    .equ SV_LINKS, 16
    .equ SV_OBS, 20
    .equ SV_LAW, 36
    .equ SV_LAST_CYCLE, 140
    .equ SV_HAS_CYCLE, 144
    .equ SV_SINCE_CYCLE, 146
    .equ SV_SINCE_START, 150
    .equ SV_HOLD_GOAL, 154
    .equ SV_HAS_HOLD_GOAL, 162
    .equ SV_HOLD, 163
    .equ SV_MEMO_URAD, 164
    .equ SV_MEMO_Q16, 172
    .equ SV_ARREST, 180
    .equ SV_CLOCK, 188
    .equ SV_ARREST_DUE, 192
    .equ SV_LOG, 194
    /* LinkConst::proximate */
    .equ K_PROXIMATE, 136
    /* ArrestLog */
    .equ LOG_N, 0
    .equ LOG_KEPT, 4
    .equ LOG_T, 8
    .equ LOG_ARREST, 520
    /* Output */
    .equ F_DAC, 0
    .equ F_ENABLE, 4
    .equ F_THETA, 6
    .equ F_OMEGA, 14
    .equ F_ARREST, 22
    .equ F_TORQUE, 30
    .equ F_GOAL, 38
    .equ F_TICKS, 46
    .equ F_HOLD, 48
    .equ F_NEW_FAULT, 49
    .equ F_REGIME, 50
    .equ F_ARREST_NEW, 52
    .equ HOLD_NONE, 255         /* Option<Hold>::None (this rustc puts the niche at 255) */
    .equ HOLD_STALE, 1          /* servo::Hold::Stale, OutOfRange (repr(u8)) */
    .equ HOLD_OUT_OF_RANGE, 3
    /* servo::params::TIMER_TICK_Q40, servo's STALE_Q32, OBSERVER_SETTLE_Q32,
     * ANGLE_LIMIT_URAD and urad_to_q16's multiplier (servo::layout asserts them) */
    .equ TIMER_TICK_Q40, 549756
    .if (TIMER_TICK_Q40 & 255) - 124
    .error "__servo_pass's period takes TIMER_TICK_Q40 as 2147 * 256 + 124"
    .endif
    .equ STALE_Q32, 85899346
    .equ SETTLE_Q32, 128849019
    .equ ANGLE_LIMIT_URAD, 25000000
    .equ URAD_TO_Q16_Q32, 281474977

    .section .text.__servo_pass, "ax"
    .globl __servo_pass
__servo_pass:
    movem.l %d2-%d7/%a2-%a6, -(%sp) /* arguments now at 48, 52, 56, 60 */
    movea.l 48(%sp), %a6        /* s */
    movea.l 52(%sp), %a0        /* io */
    movea.l 56(%sp), %a1        /* sub */
    movea.l 60(%sp), %a4        /* out */
    bsr     servo_pass_body
    movem.l (%sp)+, %d2-%d7/%a2-%a6
    rts

/* The routine's body, for it and __servo_board_pass: a6 = s, a0 = io, a1 = sub, a4 = out;
 * d0 = the result; d1-d7, a0-a6 clobbered (a6 kept). */
servo_pass_body:
    movem.l %a1/%a4, -(%sp)     /* sub at 0(sp), out at 4(sp) */
    /* started, both links proximate */
    tst.b   (%a6)               /* started */
    beq     .Lpass_rust
    movea.l SV_LINKS(%a6), %a2
    tst.b   K_PROXIMATE(%a2)
    beq     .Lpass_rust
    tst.b   LINK_CONST_BYTES+K_PROXIMATE(%a2)
    beq     .Lpass_rust
    /* the period: ticks = timer - last_timer (u16); dt = mul_shr(ticks, TIMER_TICK_Q40, 8) */
    moveq   #0, %d3
    move.w  4(%a0), %d3
    sub.w   SV_LAST_TIMER(%a6), %d3
    move.l  %d3, %d5            /* the ticks, written once the pass is the common one */
    /* TIMER_TICK_Q40 = 2147 * 256 + 124, so mul_shr(ticks, it, 8) for ticks < 2^16 is
     * ticks * 2147 + (ticks * 124 + 128) >> 8, exactly and far from overflow: one MULU.W
     * and shifts for the MULS.L, its rounding and its range check */
    move.l  %d3, %d1
    mulu.w  #(TIMER_TICK_Q40 >> 8), %d3
    lsl.l   #5, %d1             /* ticks * 124 = (ticks * 31) << 2 */
    sub.l   %d5, %d1
    lsl.l   #2, %d1
    add.l   #128, %d1
    lsr.l   #8, %d1
    add.l   %d1, %d3
    /* the subgoal's verdict d6 (a Hold, or HOLD_NONE), nothing changed yet: out of range
     * when a goal is beyond the angle limit */
    moveq   #-1, %d6            /* HOLD_NONE's byte */
    move.l  (%a1), %d0
    tst.l   %d0                 /* (MOVE sets N too; the image check wants the test) */
    bpl.s   1f
    neg.l   %d0
1:  cmpi.l  #ANGLE_LIMIT_URAD, %d0
    bhi.s   2f                  /* unsigned: i32::MIN's magnitude is 2^31 */
    move.l  4(%a1), %d0
    tst.l   %d0
    bpl.s   11f
    neg.l   %d0
11: cmpi.l  #ANGLE_LIMIT_URAD, %d0
    bls.s   12f
2:  moveq   #HOLD_OUT_OF_RANGE, %d6
12: /* the cycle's age d4: 0 for a new cycle, else sat(age + dt); else stale above STALE */
    moveq   #0, %d4
    move.l  8(%a1), %d0
    tst.b   SV_HAS_CYCLE(%a6)
    beq.s   3f
    cmp.l   SV_LAST_CYCLE(%a6), %d0
    bne.s   3f
    move.l  SV_SINCE_CYCLE(%a6), %d4
    add.l   %d3, %d4
    SATV    %d4
    cmpi.b  #HOLD_NONE, %d6
    bne.s   3f
    cmpi.l  #STALE_Q32, %d4
    ble.s   3f
    moveq   #HOLD_STALE, %d6
3:  /* a hold whose goal is chosen already: here; a new one (its goal from the arrest log or
     * the arrest point) in the Rust */
    cmpi.b  #HOLD_NONE, %d6
    beq.s   13f
    tst.b   SV_HAS_HOLD_GOAL(%a6)
    beq     .Lpass_rust
13: /* the pass: from here on it changes the state. The hold: new as a fault when its
     * reason changed; none clears the hold goal */
    move.w  %d5, F_TICKS(%a4)
    move.b  #1, F_ENABLE(%a4)
    move.b  %d6, F_HOLD(%a4)
    move.b  #HOLD_NONE, F_NEW_FAULT(%a4)
    cmpi.b  #HOLD_NONE, %d6
    bne.s   14f
    clr.b   SV_HAS_HOLD_GOAL(%a6)
    bra.s   15f
14: cmp.b   SV_HOLD(%a6), %d6
    beq.s   15f
    move.b  %d6, F_NEW_FAULT(%a4)
15: move.b  %d6, SV_HOLD(%a6)
    move.l  %d0, SV_LAST_CYCLE(%a6)
    move.b  #1, SV_HAS_CYCLE(%a6)
    move.l  %d4, SV_SINCE_CYCLE(%a6)
    /* the extended counts (wrapping), the encoder latches and the timer kept */
    move.w  (%a0), %d0
    sub.w   SV_LAST_ENC(%a6), %d0
    ext.l   %d0
    add.l   %d0, SV_COUNTS(%a6)
    move.w  2(%a0), %d0
    sub.w   SV_LAST_ENC+2(%a6), %d0
    ext.l   %d0
    add.l   %d0, SV_COUNTS+4(%a6)
    move.l  (%a0), SV_LAST_ENC(%a6)
    move.w  4(%a0), SV_LAST_TIMER(%a6)
    movea.l %d3, %a5            /* dt */
    /* link 1: the angle, the observer */
    movea.l SV_LINKS(%a6), %a0
    lea     SV_COUNTS(%a6), %a3
    bsr     servo_angle
    move.l  %d2, F_THETA(%a4)
    lea     SV_OBS(%a6), %a1
    lea     SV_LAW(%a6), %a2
    move.l  %a5, %d3
    bsr     servo_observe_body
    move.l  %d0, F_OMEGA(%a4)
    /* link 2 */
    lea     LINK_CONST_BYTES(%a0), %a0
    addq.l  #4, %a3
    bsr     servo_angle
    move.l  %d2, F_THETA+4(%a4)
    lea     SV_OBS+OBSERVER_BYTES(%a6), %a1
    lea     SV_LAW+LINK_STATE_BYTES(%a6), %a2
    move.l  %a5, %d3
    bsr     servo_observe_body
    move.l  %d0, F_OMEGA+4(%a4)
    /* the log's clock += dt >> 8 (Q24 s); every other pass the arrest points, kept and
     * logged at it (servo::Servo::log_arrest) */
    move.l  %a5, %d1
    asr.l   #8, %d1
    add.l   SV_CLOCK(%a6), %d1
    move.l  %d1, SV_CLOCK(%a6)
    tst.b   SV_ARREST_DUE(%a6)
    bne.s   21f
    move.b  #1, SV_ARREST_DUE(%a6)  /* not this pass: the last ones */
    clr.b   F_ARREST_NEW(%a4)
    bra     22f
21: clr.b   SV_ARREST_DUE(%a6)
    move.b  #1, F_ARREST_NEW(%a4)
    lea     SV_LAW(%a6), %a2
    move.l  F_THETA(%a4), %d2
    move.l  F_OMEGA(%a4), %d0
    bsr     servo_arrest_body
    move.l  %d0, SV_ARREST(%a6)
    lea     SV_LAW+LINK_STATE_BYTES(%a6), %a2
    move.l  F_THETA+4(%a4), %d2
    move.l  F_OMEGA+4(%a4), %d0
    bsr     servo_arrest_body
    move.l  %d0, SV_ARREST+4(%a6)
    lea     SV_LOG(%a6), %a0
    move.l  LOG_N(%a0), %d0
    moveq   #127, %d1
    and.l   %d0, %d1
    add.l   %d1, %d1
    add.l   %d1, %d1
    move.l  SV_CLOCK(%a6), LOG_T(%a0,%d1.l)
    add.l   %d1, %d1
    lea     LOG_ARREST(%a0), %a1
    adda.l  %d1, %a1
    move.l  SV_ARREST(%a6), (%a1)+
    move.l  SV_ARREST+4(%a6), (%a1)
    addq.l  #1, %d0
    move.l  %d0, LOG_N(%a0)
    move.l  LOG_KEPT(%a0), %d0
    move.l  %d0, %d1
    lsr.l   #7, %d1
    addq.l  #1, %d0
    sub.l   %d1, %d0
    move.l  %d0, LOG_KEPT(%a0)
22: move.l  SV_ARREST(%a6), F_ARREST(%a4)
    move.l  SV_ARREST+4(%a6), F_ARREST+4(%a4)
    /* the goal: holding, the hold goal; else urad_to_q16 of both (mul_shr(g,
     * URAD_TO_Q16_Q32, 32)), converted again only when they changed (servo::Servo::goal_q16's
     * memo) */
    cmpi.b  #HOLD_NONE, F_HOLD(%a4)
    beq.s   16f
    move.l  SV_HOLD_GOAL(%a6), F_GOAL(%a4)
    move.l  SV_HOLD_GOAL+4(%a6), F_GOAL+4(%a4)
    bra.s   17f
16: movea.l (%sp), %a1
    move.l  (%a1), %d0
    move.l  4(%a1), %d2
    cmp.l   SV_MEMO_URAD(%a6), %d0
    bne.s   7f
    cmp.l   SV_MEMO_URAD+4(%a6), %d2
    beq.s   8f
7:  move.l  %d0, SV_MEMO_URAD(%a6)
    move.l  %d2, SV_MEMO_URAD+4(%a6)
    MULSHR  %d0, #URAD_TO_Q16_Q32, 32, %d1, %d7, %d7
    move.l  %d0, SV_MEMO_Q16(%a6)
    move.l  %d2, %d0
    MULSHR  %d0, #URAD_TO_Q16_Q32, 32, %d1, %d7, %d7
    move.l  %d0, SV_MEMO_Q16+4(%a6)
8:  move.l  SV_MEMO_Q16(%a6), F_GOAL(%a4)
    move.l  SV_MEMO_Q16+4(%a6), F_GOAL+4(%a4)
17:
    /* the observers' settling clock: settled once it reached SETTLE, else it counts
     * min(dt, MAX_DT) (wrapping, as the release build's +=) */
    suba.l  %a3, %a3            /* a3 = settled (0) */
    move.l  SV_SINCE_START(%a6), %d0
    cmpi.l  #SETTLE_Q32, %d0
    blt.s   4f
    movea.w #1, %a3
    bra.s   5f
4:  move.l  %a5, %d1
    cmpi.l  #MAX_DT_Q32, %d1
    ble.s   6f
    move.l  #MAX_DT_Q32, %d1
6:  add.l   %d1, %d0
    move.l  %d0, SV_SINCE_START(%a6)
5:  /* the law of both links: err = theta - goal (wrapping); a4 = dt, a5 = settled */
    exg     %a3, %a5
    movea.l %a3, %a4
    movea.l SV_LINKS(%a6), %a2
    lea     SV_LAW(%a6), %a3
    movea.l 4(%sp), %a0
    move.l  F_THETA(%a0), %d2
    sub.l   F_GOAL(%a0), %d2
    move.l  F_OMEGA(%a0), %d3
    bsr     servo_control_body
    movea.l 4(%sp), %a0
    move.w  %d0, F_DAC(%a0)
    swap    %d0
    move.b  %d0, F_REGIME(%a0)
    move.l  S_TORQUE(%a3), F_TORQUE(%a0)
    lea     LINK_CONST_BYTES(%a2), %a2
    lea     LINK_STATE_BYTES(%a3), %a3
    move.l  F_THETA+4(%a0), %d2
    sub.l   F_GOAL+4(%a0), %d2
    move.l  F_OMEGA+4(%a0), %d3
    bsr     servo_control_body
    movea.l 4(%sp), %a0
    move.w  %d0, F_DAC+2(%a0)
    swap    %d0
    move.b  %d0, F_REGIME+1(%a0)
    move.l  S_TORQUE(%a3), F_TORQUE+4(%a0)
    moveq   #1, %d0
    addq.l  #8, %sp
    rts
.Lpass_rust:
    moveq   #0, %d0
    addq.l  #8, %sp
    rts

/* ---- the board's common pass ----
 * u32 __servo_board_pass(PassState *b, const Ports *p): board_servo's PassState::run for a
 * pass whose subgoal record reads whole within four tries and whose servo pass is
 * __servo_pass's: latch and read both encoders, read the timer, read the subgoal record
 * (sequence, four words, sequence) and keep it, run __servo_pass into b->out (the caller
 * reads its hold and new fault there), write both DACs and the amplifier enables, count
 * the time and the pass, and either keep the pass's state (a pass that computed the
 * arrest points) or publish the state kept on the pass before under its sequence lock (the
 * six angles in urad as servo::q16_to_urad, the torques in mN m). Returns 1; or 0 when the
 * record is torn or was never published, or __servo_pass
 * returned 0, having changed nothing but the encoder latch and the subgoal kept (the Rust
 * then runs the pass and reads both again).
 * Offsets: board_servo's layout module asserts them. */
    /* PassState */
    .equ B_TICKS, 0
    .equ B_LOOPS, 8
    .equ B_LAST_SUB, 12
    .equ B_HAS_SUB, 24
    .equ B_TORN, 25
    .equ B_OUT, 26
    .equ B_SNAP, 80
    .equ B_SNAP_T, 112
    .equ B_SNAP_LOOPS, 116
    .equ B_SERVO, 120
    /* Ports */
    .equ P_LATCH, 0
    .equ P_ENC0, 4
    .equ P_ENC1, 8
    .equ P_TIMER, 12
    .equ P_DAC0, 16
    .equ P_DAC1, 20
    .equ P_AMP, 24
    .equ P_SUB, 28
    .equ P_STATE, 32
    /* regs::servo::EncCtrl::LATCH, AmpCtrl::ENABLE0 | ENABLE1 */
    .equ ENC_LATCH, 1
    .equ AMP_BOTH, 3
    /* vme_map's SeqLock::RETRIES (board_servo's layout asserts it) */
    .equ SUB_TRIES, 4

/* Q16_TO_URAD r, t, u, ten: r = servo::q16_to_urad(r): 15 r + (265 r + 512) >> 10 within
 * +-2^22, else mul_shr(r, 10^6, 16) (out of line); t, u scratch data registers, ten a data
 * register holding 10. */
.macro Q16_TO_URAD r, t, u, ten
    move.l  \r, \t
    addi.l  #0x400000, \t
    cmpi.l  #0x800000, \t
    bcc     .Lqb\@
    move.l  \r, \t
    lsl.l   #4, \t
    sub.l   \r, \t              /* 15 r */
    move.l  \r, \u
    lsl.l   #8, \u
    add.l   \r, \u              /* 257 r */
    lsl.l   #3, \r
    add.l   \u, \r              /* 265 r */
    addi.l  #512, \r
    asr.l   \ten, \r             /* one barrel shift: 6 cycles, two by 8 and 2 take 12 */
    add.l   \t, \r
.Lqd\@:
    .subsection 1
.Lqb\@:
    MULSHR  \r, #1000000, 16, \t, \u, \u
    .subsection 1               /* (MULSHR ends in subsection 0) */
    bra     .Lqd\@
    .subsection 0
.endm

/* MNM r, t: r = (r * 1000) >> 16 (wrapping, as the board's), 1000 r as 1024 r - 24 r. */
.macro MNM r, t
    move.l  \r, \t
    lsl.l   #3, \t              /* 8 r */
    lsl.l   #8, \r
    lsl.l   #2, \r              /* 1024 r */
    sub.l   \t, \r
    add.l   \t, \t
    sub.l   \t, \r              /* 1000 r */
    swap    \r
    ext.l   \r                  /* >> 16 */
.endm

    .section .text.__servo_board_pass, "ax"
    .globl __servo_board_pass
__servo_board_pass:
    movem.l %d2-%d7/%a2-%a6, -(%sp) /* arguments now at 48, 52 */
    movea.l 48(%sp), %a2        /* b */
    movea.l 52(%sp), %a3        /* p */
    subq.l  #6, %sp             /* servo::Input's head: enc[2], timer; arguments at 54, 58 */
    movea.l P_LATCH(%a3), %a0
    move.w  #ENC_LATCH, (%a0)
    movea.l P_ENC0(%a3), %a0
    move.w  (%a0), (%sp)
    movea.l P_ENC1(%a3), %a0
    move.w  (%a0), 2(%sp)
    movea.l P_TIMER(%a3), %a0
    move.w  (%a0), 4(%sp)
    /* the subgoal record, up to SUB_TRIES tries as SeqLock::read_raw makes them: whole
     * when both sequences are the same and even (a read that met the reflex mid-write,
     * some 2.6% of the passes, took the Rust's way, 700-1,100 cycles longer); 0: never
     * published */
    moveq   #SUB_TRIES-1, %d5
28: movea.l P_SUB(%a3), %a0
    move.l  (%a0)+, %d0         /* sequence */
    move.l  (%a0)+, %d1         /* goal 1 */
    move.l  (%a0)+, %d2         /* goal 2 */
    addq.l  #4, %a0             /* (flags) */
    move.l  (%a0), %d3          /* cycle */
    movea.l P_SUB(%a3), %a0
    move.l  (%a0), %d4
    cmp.l   %d0, %d4
    bne.s   29f
    btst    #0, %d0
    beq.s   30f
29: dbra    %d5, 28b
    bra     .Lbp_rust
30: tst.l   %d0
    beq     .Lbp_rust
    move.l  %d1, B_LAST_SUB(%a2)
    move.l  %d2, B_LAST_SUB+4(%a2)
    move.l  %d3, B_LAST_SUB+8(%a2)
    move.b  #1, B_HAS_SUB(%a2)
    clr.b   B_TORN(%a2)
    /* the servo's pass into b->out: __servo_pass's body */
    lea     B_SERVO(%a2), %a6
    movea.l %sp, %a0
    lea     B_LAST_SUB(%a2), %a1
    lea     B_OUT(%a2), %a4
    jsr     servo_pass_body
    tst.l   %d0
    beq     .Lbp_rust
    movea.l 54(%sp), %a2
    movea.l 58(%sp), %a3
    /* the DACs (codes within DAC_MIN..DAC_MAX: 12 bits) and both amplifiers enabled */
    move.w  B_OUT+F_DAC(%a2), %d0
    andi.w  #0xfff, %d0
    movea.l P_DAC0(%a3), %a0
    move.w  %d0, (%a0)
    move.w  B_OUT+F_DAC+2(%a2), %d0
    andi.w  #0xfff, %d0
    movea.l P_DAC1(%a3), %a0
    move.w  %d0, (%a0)
    movea.l P_AMP(%a3), %a0
    move.w  #AMP_BOTH, (%a0)
    /* ticks += period (u64); t_us = ticks >> 1 (low 32 bits) in d5; loops += 1 in d4 */
    moveq   #0, %d0
    move.w  B_OUT+F_TICKS(%a2), %d0
    move.l  B_TICKS(%a2), %d1
    move.l  B_TICKS+4(%a2), %d2
    add.l   %d0, %d2
    moveq   #0, %d0
    addx.l  %d0, %d1
    move.l  %d1, B_TICKS(%a2)
    move.l  %d2, B_TICKS+4(%a2)
    lsr.l   #1, %d1             /* X = the high word's low bit */
    roxr.l  #1, %d2
    move.l  %d2, %d5
    move.l  B_LOOPS(%a2), %d4
    addq.l  #1, %d4
    move.l  %d4, B_LOOPS(%a2)
    /* the state every other pass: a pass that computed the arrest points keeps its
     * state (angles, speeds, arrest points, torques: eight words in a row from theta; its
     * time and count), the next publishes it */
    tst.b   B_OUT+F_ARREST_NEW(%a2)
    beq.s   27f
    lea     B_OUT+F_THETA(%a2), %a0
    lea     B_SNAP(%a2), %a1
    .rept 8
    move.l  (%a0)+, (%a1)+
    .endr
    move.l  %d5, (%a1)+         /* B_SNAP_T */
    move.l  %d4, (%a1)          /* B_SNAP_LOOPS */
    bra     .Lbp_done
27: /* the kept state, built on the stack: ten words */
    lea     -40(%sp), %sp
    movea.l %sp, %a1
    lea     B_SNAP(%a2), %a0    /* theta, omega, arrest: six words in a row */
    moveq   #10, %d3
    .rept 6
    move.l  (%a0)+, %d0
    Q16_TO_URAD %d0, %d1, %d2, %d3
    move.l  %d0, (%a1)+
    .endr
    move.l  (%a0)+, %d0         /* the torques */
    MNM     %d0, %d1
    move.l  %d0, (%a1)+
    move.l  (%a0)+, %d0
    MNM     %d0, %d1
    move.l  %d0, (%a1)+
    move.l  (%a0)+, (%a1)+      /* t_us */
    move.l  (%a0), (%a1)        /* loops */
    /* publish: sequence odd ((seq | 1) + 2 when a writer died mid-write), the words, even */
    movea.l P_STATE(%a3), %a0
    move.l  (%a0), %d0
    moveq   #1, %d1
    and.l   %d0, %d1
    add.l   %d1, %d1
    bset    #0, %d0
    add.l   %d1, %d0
    move.l  %d0, (%a0)+
    movea.l %sp, %a1
    .rept 10
    move.l  (%a1)+, (%a0)+
    .endr
    addq.l  #1, %d0
    movea.l P_STATE(%a3), %a0
    move.l  %d0, (%a0)
    lea     40(%sp), %sp
.Lbp_done:
    addq.l  #6, %sp
    moveq   #1, %d0
    movem.l (%sp)+, %d2-%d7/%a2-%a6
    rts
.Lbp_rust:
    addq.l  #6, %sp
    moveq   #0, %d0
    movem.l (%sp)+, %d2-%d7/%a2-%a6
    rts

/* ---- the arrest log's look-up (servo::arrest_log::ArrestLog::at_age) ----
 * void __servo_at_age(const ArrestLog *log, u32 now, u32 age, const i32 fallback[2],
 *                     i32 out[2]): out = the arrest point of the newest entry at least age
 * before now ((now - t) - age >= 0 as an i32, wrapping), else of the oldest kept, else
 * fallback when nothing is kept. From the newest back, stopping at the first old enough:
 * ~20 cycles an entry, at most 128 (the compiled branch-free loop took ~27,000 cycles, the
 * whole of a hold's first pass over again when an input went stale). Offsets: servo::layout
 * asserts them (LOG_*). */
    .section .text.__servo_at_age, "ax"
    .globl __servo_at_age
__servo_at_age:
    movem.l %d2-%d4, -(%sp)     /* arguments now at 16, 20, 24, 28, 32 */
    movea.l 16(%sp), %a0        /* log */
    movea.l 32(%sp), %a1        /* out */
    move.l  LOG_KEPT(%a0), %d3
    tst.l   %d3                 /* (MOVE sets Z too; the image check wants the test) */
    bne.s   1f
    movea.l 28(%sp), %a0        /* nothing kept: the fallback */
    move.l  (%a0)+, (%a1)+
    move.l  (%a0), (%a1)
    movem.l (%sp)+, %d2-%d4
    rts
1:  move.l  20(%sp), %d1        /* now */
    move.l  24(%sp), %d2        /* age */
    move.l  LOG_N(%a0), %d0
    subq.l  #1, %d0             /* the newest */
    subq.l  #1, %d3             /* kept - 1 more after the first (DBRA) */
2:  moveq   #127, %d4
    and.l   %d0, %d4            /* its index */
    move.l  %d1, %d0
    sub.l   LOG_T(%a0,%d4.l*4), %d0
    sub.l   %d2, %d0
    bpl.s   3f                  /* (now - t) - age >= 0: old enough */
    move.l  %d4, %d0
    subq.l  #1, %d0             /* the next older */
    dbra    %d3, 2b
3:  /* d4: the entry found, or the oldest kept */
    lea     LOG_ARREST(%a0), %a0
    move.l  (%a0,%d4.l*8), (%a1)+
    move.l  4(%a0,%d4.l*8), (%a1)
    movem.l (%sp)+, %d2-%d4
    rts
