/* The 68020 runtime's assembly (crates/rt; design.md section 8).
 *
 * Assembled by GNU as (binutils-m68k-linux-gnu, -m68020) from rt's build script: LLVM's
 * M68k assembler rejects much of the 68020 instruction set and silently mis-assembles some
 * of it (docs/toolchain.md). Motorola syntax with % registers.
 *
 * Only the C ABI's scratch registers (d0, d1, a0, a1) are used by the callable routines;
 * pointers are returned in both d0 and a0.
 */

/* ---- vector table: 256 longs at address 0 ---- */
    .section .vectors, "a"
    .globl __vectors
__vectors:
    .long _stack_top            /* 0: initial SSP */
    .long _reset                /* 1: reset PC */
    .rept 254
    .long _exception            /* 2..255: every exception and interrupt */
    .endr

/* ---- reset: mask interrupts, stack, .data copy, .bss clear, Rust ---- */
    .section .text._reset, "ax"
    .globl _reset
_reset:
    move.w  #0x2700, %sr
    /* The stack pointer is vector 0's _stack_top, loaded by the reset itself. In the six
     * bytes a `lea _stack_top, %sp` took here (so that no code after moves, and no branch
     * changes its alignment): the instruction cache cleared and enabled (CACR CI | EI),
     * 64 long words the main loops' inner loops run from (User's Manual section 6). */
    moveq   #9, %d0
    movec   %d0, %cacr
    /* .data from its load address, then .bss cleared, by the runtime's own memcpy and
     * memset (32 bytes a pass: a board whose state is 14 KiB of initialised data, the
     * planner, starts in a third of the time a long-at-a-time loop took). */
    lea     _sdata, %a1
    move.l  #_edata, %d0
    sub.l   %a1, %d0
    move.l  %d0, -(%sp)         /* n */
    pea     _sidata             /* src */
    move.l  %a1, -(%sp)         /* dst */
    jsr     memcpy
    lea     12(%sp), %sp
    lea     _edata, %a1         /* = _sbss (the linker script keeps them adjacent) */
    move.l  #_ebss, %d0
    sub.l   %a1, %d0
    move.l  %d0, -(%sp)         /* n */
    clr.l   -(%sp)              /* c */
    move.l  %a1, -(%sp)         /* dst */
    jsr     memset
    lea     12(%sp), %sp
    jsr     __rt_start
5:  bra.s   5b

/* ---- common exception entry: the 68020 stacks SR, PC and a format/vector word ---- */
    .section .text._exception, "ax"
    .globl _exception
_exception:
    move.w  #0x2700, %sr
    move.l  %sp, -(%sp)         /* argument: the exception frame */
    jsr     __rt_exception
6:  bra.s   6b

/* ---- SR access for the critical section ---- */
    .section .text.__rt_sr, "ax"
    .globl __rt_sr_mask_all
__rt_sr_mask_all:               /* u32 __rt_sr_mask_all(void): old SR, mask raised to 7 */
    move.w  %sr, %d0            /* first, so the value is the SR at the call */
    andi.l  #0xffff, %d0
    ori.w   #0x0700, %sr
    rts
    .globl __rt_sr_restore
__rt_sr_restore:                /* void __rt_sr_restore(u32 sr) */
    move.l  4(%sp), %d0
    move.w  %d0, %sr
    rts
    .globl __rt_halt
__rt_halt:                      /* never returns: STOP with every interrupt masked */
7:  stop    #0x2700
    bra.s   7b

/* ---- memory routines (compiler-builtins' are miscompiled: docs/toolchain.md) ---- */
    .section .text.__rt_mem, "ax"   /* one section: kept whole whenever memcpy is used */
    .globl memcpy
memcpy:                         /* void *memcpy(void *dst, const void *src, size_t n) */
    movea.l 4(%sp), %a0
    movea.l 8(%sp), %a1
    move.l  12(%sp), %d1
    move.l  %a0, %d0
    btst    #0, %d0
    bne.s   3f
    move.l  %a1, %d0
    btst    #0, %d0
    bne.s   3f
    /* Both even: 32 bytes a pass (eight longs; the 68020 moves a long on any even
     * address, and unrolled the planner board's 14 KiB of state moves in half the time),
     * then the 0-7 longs left by a jump into the last seven moves (no loop: most copies
     * are records and small structs), then a word and a byte. */
    move.l  %d1, %d0
    lsr.l   #5, %d0
    beq.s   6f
5:
    .rept   8
    move.l  (%a1)+, (%a0)+
    .endr
    subq.l  #1, %d0
    bne.s   5b
6:  moveq   #28, %d0            /* bytes in the longs left, 0-28 */
    and.l   %d1, %d0
    lsr.l   #1, %d0             /* two bytes of code a long */
    neg.l   %d0
    jmp     7f(%pc, %d0.l)
    .rept   7
    move.l  (%a1)+, (%a0)+
    .endr
7:  btst    #1, %d1
    beq.s   8f
    move.w  (%a1)+, (%a0)+
8:  btst    #0, %d1
    beq.s   4f
    move.b  (%a1)+, (%a0)+
    bra.s   4f
3:  tst.l   %d1                 /* an odd address: byte by byte */
    beq.s   4f
    move.b  (%a1)+, (%a0)+
    subq.l  #1, %d1
    bra.s   3b
4:  move.l  4(%sp), %d0
    movea.l %d0, %a0
    rts

    .globl memmove
memmove:                        /* void *memmove(void *dst, const void *src, size_t n) */
    movea.l 4(%sp), %a0
    movea.l 8(%sp), %a1
    move.l  12(%sp), %d1
    cmpa.l  %a1, %a0
    bls     memcpy              /* dst <= src: a forward copy is safe */
    move.l  %a1, %d0
    add.l   %d1, %d0
    cmpa.l  %d0, %a0
    bcc     memcpy              /* dst >= src + n: no overlap */
    adda.l  %d1, %a0
    adda.l  %d1, %a1
1:  tst.l   %d1
    beq.s   2f
    move.b  -(%a1), -(%a0)
    subq.l  #1, %d1
    bra.s   1b
2:  move.l  4(%sp), %d0
    movea.l %d0, %a0
    rts

    .globl memset
memset:                         /* void *memset(void *dst, int c, size_t n) */
    movea.l 4(%sp), %a0
    moveq   #0, %d0
    move.b  11(%sp), %d0        /* c's low byte (big-endian int at 8(%sp)) */
    tst.b   %d0
    beq.s   1f                  /* zero (most calls) needs no spreading */
    mulu.l  #0x01010101, %d0    /* the byte in all four lanes */
1:  move.l  12(%sp), %d1
    move.l  %a0, -(%sp)         /* arguments now 4 bytes further up */
    btst    #0, 3(%sp)
    beq.s   5f
    tst.l   %d1                 /* odd dst: one byte first, then longs */
    beq.s   4f
    move.b  %d0, (%a0)+
    subq.l  #1, %d1
    /* 32 bytes a pass (eight longs; the 68020 stores one on any even address), then the
     * 0-7 longs left by a jump into the last seven stores, then a word and a byte. */
5:  move.l  %d1, -(%sp)
    lsr.l   #5, %d1
    beq.s   6f
2:
    .rept   8
    move.l  %d0, (%a0)+
    .endr
    subq.l  #1, %d1
    bne.s   2b
6:  moveq   #28, %d1            /* bytes in the longs left, 0-28 */
    and.l   (%sp), %d1
    lsr.l   #1, %d1             /* two bytes of code a long */
    neg.l   %d1
    jmp     7f(%pc, %d1.l)
    .rept   7
    move.l  %d0, (%a0)+
    .endr
7:  move.l  (%sp)+, %d1
    btst    #1, %d1
    beq.s   8f
    move.w  %d0, (%a0)+
8:  btst    #0, %d1
    beq.s   4f
    move.b  %d0, (%a0)+
4:  move.l  (%sp)+, %d0         /* dst */
    movea.l %d0, %a0
    rts

    .globl memcmp
    .globl bcmp
memcmp:                         /* int memcmp(const void *a, const void *b, size_t n) */
bcmp:
    movea.l 4(%sp), %a0
    movea.l 8(%sp), %a1
    move.l  12(%sp), %d1
1:  tst.l   %d1
    beq.s   3f
    moveq   #0, %d0
    move.b  (%a0)+, %d0
    cmp.b   (%a1)+, %d0
    bne.s   2f
    subq.l  #1, %d1
    bra.s   1b
2:  moveq   #0, %d1
    move.b  -(%a1), %d1
    sub.l   %d1, %d0
    rts
3:  moveq   #0, %d0
    rts

/* ---- indivisible compare-and-swap on global RAM (vme-map's GlobalBus::cas_u32) ---- */
    .section .text.__vme_cas32, "ax"
    .globl __vme_cas32
__vme_cas32:                    /* u32 __vme_cas32(u32 *addr, u32 current, u32 new): value found */
    movea.l 4(%sp), %a0
    move.l  8(%sp), %d0
    move.l  12(%sp), %d1
    cas.l   %d0, %d1, (%a0)     /* equal: store new; else d0 = value found */
    rts

/* ---- atomic raise of a word: a C-space column's generation (GlobalBus::raise_u32) ----
 * void __vme_raise32(u32 *addr): *addr += 1 against every other board's CAS.L on the word
 * (a failed CAS.L leaves the value found in d0; try again from it). */
    .section .text.__vme_raise32, "ax"
    .globl __vme_raise32
__vme_raise32:
    movea.l 4(%sp), %a0
    move.l  (%a0), %d0
1:  move.l  %d0, %d1
    addq.l  #1, %d1
    cas.l   %d0, %d1, (%a0)     /* equal: store d0 + 1; else d0 = value found */
    bne.s   1b
    rts

/* ---- two atomic raises: a column's generation, then the map's epoch ----
 * void __vme_raise32_then(u32 *first, u32 *then) (GlobalBus::raise_u32_then): *first += 1,
 * then *then += 1, each as __vme_raise32. The loop written twice: entered by BSR into
 * __vme_raise32's, the job cost what two calls cost (bench cspace worst 313,673 cycles
 * against 311,867 inline and 313,469 as two calls). */
    .section .text.__vme_raise32_then, "ax"
    .globl __vme_raise32_then
__vme_raise32_then:
    movea.l 4(%sp), %a0
    move.l  (%a0), %d0
1:  move.l  %d0, %d1
    addq.l  #1, %d1
    cas.l   %d0, %d1, (%a0)
    bne.s   1b
    movea.l 8(%sp), %a0
    move.l  (%a0), %d0
2:  move.l  %d0, %d1
    addq.l  #1, %d1
    cas.l   %d0, %d1, (%a0)
    bne.s   2b
    rts

/* ---- leading zero words: the free rows of a C-space column (GlobalBus::zero_run) ----
 * u32 __vme_zero_run(const u32 *addr, u32 n, u32 stride): how many of the n words stride
 * bytes apart are zero before the first that is not (n when none is). */
    .section .text.__vme_zero_run, "ax"
    .globl __vme_zero_run
__vme_zero_run:
    movea.l 4(%sp), %a0
    move.l  8(%sp), %d1
    move.l  12(%sp), %a1
    moveq   #0, %d0
    tst.l   %d1
    beq.s   9f
1:  tst.l   (%a0)
    bne.s   9f
    adda.l  %a1, %a0
    addq.l  #1, %d0
    cmp.l   %d1, %d0
    bne.s   1b
9:  rts

/* ---- the escape's window generations (crates/reflex, escape::same_window) ----
 * u32 __reflex_gens_moved(const u32 *gens, u32 c0, u32 *saved, u32 n): which of the
 * generation words gens[(c0 + k) mod 128], k = 0 .. n (0 < n <= 32, c0 < 128), are not
 * saved[k]: bit k for each, 0 when none (then nothing is written), every one copied into
 * saved otherwise: the window's columns written since the words were saved. Compared with
 * CMPM.L in at most two runs that do not wrap (the usual answer, none written, reads each
 * pair once); when one differs, each pair again from the last down, its bit shifted in. */
    .section .text.__reflex_gens_moved, "ax"
    .globl __reflex_gens_moved
__reflex_gens_moved:
    movem.l %d2-%d3/%a2, -(%sp)     /* 12 bytes: arguments from 16(%sp) */
    movea.l 16(%sp), %a2            /* gens */
    move.l  20(%sp), %d1            /* c0 */
    movea.l 24(%sp), %a1            /* saved */
    move.l  28(%sp), %d2            /* n */
    move.l  #128, %d3               /* the first run: min(128 - c0, n) words */
    sub.l   %d1, %d3
    cmp.l   %d2, %d3
    bls.s   1f
    move.l  %d2, %d3
1:  sub.l   %d3, %d2                /* the second, from column 0 */
    lea     (%a2,%d1.l*4), %a0
    subq.l  #1, %d3
2:  cmpm.l  (%a0)+, (%a1)+
    dbne    %d3, 2b
    bne.s   8f
    tst.l   %d2
    beq.s   9f
    movea.l %a2, %a0
    subq.l  #1, %d2
3:  cmpm.l  (%a0)+, (%a1)+
    dbne    %d2, 3b
    bne.s   8f
9:  moveq   #0, %d0
    movem.l (%sp)+, %d2-%d3/%a2
    rts
8:  move.l  28(%sp), %d2            /* one differs: from the last pair down */
    movea.l 24(%sp), %a1
    lea     (%a1,%d2.l*4), %a1      /* past the last saved word */
    move.l  20(%sp), %d1
    add.l   %d2, %d1                /* the column after the last, unwrapped */
    subq.l  #1, %d2
    moveq   #0, %d0
    moveq   #127, %d3
4:  subq.l  #1, %d1
    and.l   %d3, %d1
    movea.l (%a2,%d1.l*4), %a0      /* the generation now */
    add.l   %d0, %d0                /* the bits so far up one */
    cmpa.l  -(%a1), %a0
    beq.s   5f
    addq.l  #1, %d0                 /* this column moved */
    move.l  %a0, (%a1)              /* saved anew */
5:  dbra    %d2, 4b
    movem.l (%sp)+, %d2-%d3/%a2
    rts

/* ---- a column of the escape's window read again (crates/reflex, escape::put_column) ----
 * u32 __reflex_put_column(u32 *rows, u32 marked, u32 bit): for r = 0 .. 32, the bit `bit`
 * of rows[r] cleared where bit r of marked is set, set where it is not; returns `bit` when
 * a row's bit changed, else 0. LSR.L shifts bit r out into X, SUBX.L makes it a mask, and
 * the bit, set, is flipped off by the mask; old ^ new is or-ed into the answer. */
    .section .text.__reflex_put_column, "ax"
    .globl __reflex_put_column
__reflex_put_column:
    movem.l %d2-%d5, -(%sp)         /* 16 bytes: arguments from 20(%sp) */
    movea.l 20(%sp), %a0
    move.l  24(%sp), %d0
    move.l  28(%sp), %d1
    moveq   #0, %d5
    .rept 32
    lsr.l   #1, %d0
    subx.l  %d2, %d2
    and.l   %d1, %d2
    move.l  (%a0), %d3
    move.l  %d3, %d4
    or.l    %d1, %d4
    eor.l   %d2, %d4
    eor.l   %d4, %d3
    or.l    %d3, %d5
    move.l  %d4, (%a0)+
    .endr
    move.l  %d5, %d0
    movem.l (%sp)+, %d2-%d5
    rts

/* ---- a step of the escape's flood (crates/reflex, escape::step) ----
 * u32 __reflex_flood_step(u32 *reach, u32 *next, const u32 *free0, const u32 *lvl, u32 n,
 *                         u32 any, u32 *grew): over n >= 1 rows from the first, with reach
 * pointing at the row above it (reach[0]) and the others at the first row: here = reach[1],
 * d = here | here << 1 | here >> 1 | above | below (reach[2], not yet stepped), new reach
 * here | (d & (free0 | any)), its new pixels (new ^ here) into next; above = the old here.
 * Returns the or of the new pixels and lvl, *grew the or of the new pixels (the compiled
 * loop spent ~200 cycles a row on spills and bounds checks). */
    .section .text.__reflex_flood_step, "ax"
    .globl __reflex_flood_step
__reflex_flood_step:
    movem.l %d2-%d7/%a2-%a3, -(%sp) /* 32 bytes: arguments from 36(%sp) */
    movea.l 36(%sp), %a0            /* reach: the row above */
    movea.l 40(%sp), %a1            /* next */
    movea.l 44(%sp), %a2            /* free0 */
    movea.l 48(%sp), %a3            /* lvl */
    move.l  52(%sp), %d7
    move.l  56(%sp), %d6            /* any */
    moveq   #0, %d4                 /* grew */
    moveq   #0, %d5                 /* better */
    move.l  (%a0)+, %d0             /* above */
    subq.l  #1, %d7
1:  move.l  (%a0), %d1              /* here */
    move.l  %d1, %d2
    add.l   %d2, %d2
    move.l  %d1, %d3
    lsr.l   #1, %d3
    or.l    %d3, %d2
    or.l    %d1, %d2
    or.l    %d0, %d2
    or.l    4(%a0), %d2             /* below */
    move.l  (%a2)+, %d3
    or.l    %d6, %d3
    and.l   %d3, %d2
    or.l    %d1, %d2                /* the new reach */
    move.l  %d2, (%a0)+
    eor.l   %d1, %d2                /* its new pixels */
    move.l  %d2, (%a1)+
    or.l    %d2, %d4
    and.l   (%a3)+, %d2
    or.l    %d2, %d5
    move.l  %d1, %d0                /* above: the old here */
    dbra    %d7, 1b
    movea.l 60(%sp), %a0
    move.l  %d4, (%a0)
    move.l  %d5, %d0
    movem.l (%sp)+, %d2-%d7/%a2-%a3
    rts

/* ---- the reflex's known columns (crates/reflex, window::Known) ----
 * u32 __reflex_known_hits(const u32 *gens, const Known *k, u32 c, u32 n, u32 q, u32 m):
 * how many of columns c .. c + n (not wrapping), from c, k vouches for: the generation word
 * in global RAM (gens[c]) still the one k read the column at (k->gen[c]), and k's run of
 * free rows (k->start[c], k->len[c]) holding rows q .. q + m (wrapping). Known is repr(C):
 * gen u32[128] at 0, start u8[128] at 512, len u8[128] at 640 (asserted in the Rust). */
    .section .text.__reflex_known_hits, "ax"
    .globl __reflex_known_hits
__reflex_known_hits:
    movem.l %d2-%d5/%a2-%a3, -(%sp) /* 24 bytes: arguments from 28(%sp) */
    movea.l 28(%sp), %a0            /* gens */
    movea.l 32(%sp), %a1            /* k */
    move.l  36(%sp), %d0            /* c */
    move.l  44(%sp), %d2            /* q */
    move.l  48(%sp), %d3            /* m: at most 128, so (q - s) mod 128 + m fits a byte */
    lea     512(%a1,%d0.l), %a2     /* &k->start[c] */
    lea     640(%a1,%d0.l), %a3     /* &k->len[c] */
    lsl.l   #2, %d0
    adda.l  %d0, %a0                /* &gens[c] */
    adda.l  %d0, %a1                /* &k->gen[c] */
    moveq   #127, %d5
    move.l  40(%sp), %d4            /* n (at most 128) */
    moveq   #0, %d0
    subq.l  #1, %d4                 /* DBRA's count: n - 1 .. 0 */
    bmi.s   9f                      /* n = 0 */
1:  cmpm.l  (%a0)+, (%a1)+
    bne.s   8f                      /* the column was written since */
    move.b  %d2, %d1
    sub.b   (%a2)+, %d1             /* q - s, mod 256 */
    and.b   %d5, %d1                /* mod 128 */
    add.b   %d3, %d1                /* + m: at most 255 */
    cmp.b   (%a3)+, %d1
    bhi.s   8f                      /* rows beyond the run (its length l) */
    dbra    %d4, 1b
    move.l  40(%sp), %d0            /* every column vouched for */
    bra.s   9f
8:  move.l  40(%sp), %d0
    subq.l  #1, %d0
    sub.l   %d4, %d0                /* columns before this one: n - 1 - count */
9:  movem.l (%sp)+, %d2-%d5/%a2-%a3
    rts

/* ---- or of words: a row or column of the C-space map (vme-map's GlobalBus::or_words) ----
 * u32 __vme_or_words(const u32 *addr, u32 n, u32 stride): the or of n words stride bytes
 * apart. Rows (stride 4) take OR.L (An)+ with DBRA, four words a pass; other strides
 * ADDA.L. n = 0 gives 0. */
    .section .text.__vme_or_words, "ax"
    .globl __vme_or_words
__vme_or_words:
    movea.l 4(%sp), %a0
    move.l  8(%sp), %d1
    moveq   #0, %d0
    tst.l   %d1
    beq.s   9f
    cmpi.l  #4, 12(%sp)
    bne.s   5f
    /* stride 4: n / 4 passes of four words, then n % 4 words */
    move.l  %d1, -(%sp)
    lsr.l   #2, %d1
    beq.s   2f
    subq.l  #1, %d1
1:  or.l    (%a0)+, %d0
    or.l    (%a0)+, %d0
    or.l    (%a0)+, %d0
    or.l    (%a0)+, %d0
    dbra    %d1, 1b
2:  move.l  (%sp)+, %d1
    andi.l  #3, %d1
    beq.s   9f
    subq.l  #1, %d1
3:  or.l    (%a0)+, %d0
    dbra    %d1, 3b
    rts
5:  move.l  %d2, -(%sp)
    move.l  16(%sp), %d2        /* stride (one word pushed) */
    subq.l  #1, %d1
6:  or.l    (%a0), %d0
    adda.l  %d2, %a0
    dbra    %d1, 6b
    move.l  (%sp)+, %d2
9:  rts

/* ---- free rows of a rectangle: the reflex's window test (vme-map's GlobalBus::free_rows) ----
 * u32 __vme_free_rows(const u32 *r0, u32 n0, const u32 *r1, u32 n1, u32 rows, u32 stride):
 * row k is the n0 words from r0 + k * stride bytes and the n1 words from r1 + k * stride
 * (n0, n1 <= 128); returns how many rows from the first are all zero (rows when every one
 * is), reading no row past the first that is not. Each run is a JSR into a block of 128
 * OR.L (An)+, 2 * n bytes before its RTS (entry points computed once): no loop counter
 * per word. n1 = 0 reads nothing of the second run. */
    .section .text.__vme_free_rows, "ax"
    .globl __vme_free_rows
__vme_free_rows:
    movem.l %d2-%d5/%a2-%a4, -(%sp) /* 28 bytes: arguments from 32(%sp) */
    movea.l 32(%sp), %a1
    move.l  36(%sp), %d2
    movea.l 40(%sp), %a2
    move.l  44(%sp), %d3
    move.l  48(%sp), %d4
    move.l  52(%sp), %d5
    lea     8f(%pc), %a3            /* run 0 enters 2 * n0 bytes before the RTS */
    suba.l  %d2, %a3
    suba.l  %d2, %a3
    lea     8f(%pc), %a4
    suba.l  %d3, %a4
    suba.l  %d3, %a4
    moveq   #0, %d0
    tst.l   %d4
    beq.s   9f
5:  moveq   #0, %d1
    movea.l %a1, %a0
    jsr     (%a3)
    tst.l   %d3
    beq.s   6f
    movea.l %a2, %a0
    jsr     (%a4)
6:  tst.l   %d1
    bne.s   9f
    addq.l  #1, %d0
    adda.l  %d5, %a1
    adda.l  %d5, %a2
    cmp.l   %d4, %d0
    bne.s   5b
9:  movem.l (%sp)+, %d2-%d5/%a2-%a4
    rts
    .rept   128
    or.l    (%a0)+, %d1
    .endr
8:  rts

/* ---- nonzero words as bits: a row of the planner's bitmap (vme-map's GlobalBus::nonzero_bits)
 * u32 __vme_nonzero_bits(const u32 *addr): bit k set when the k-th of the 32 consecutive
 * words from addr is nonzero. The words from the last down: NEG.L sets X when its operand
 * is nonzero and ADDX.L shifts X in at bit 0, so the first word's bit ends at bit 0; no
 * branch and no bit index (the TST.L / BSET loop took ~600 cycles a row). */
    .section .text.__vme_nonzero_bits, "ax"
    .globl __vme_nonzero_bits
__vme_nonzero_bits:
    movea.l 4(%sp), %a0
    lea     128(%a0), %a0
    moveq   #0, %d0
    .rept 32
    move.l  -(%a0), %d1
    neg.l   %d1
    addx.l  %d0, %d0
    .endr
    rts

/* ---- a run of a column's words as bits (GlobalBus::nonzero_bits_strided) ----
 * u32 __vme_nonzero_bits_strided(const u32 *last, u32 n, u32 stride): bit k set when the
 * k-th of the n words (0 < n <= 32) stride bytes apart ending at last is nonzero. From the
 * last word up, as __vme_nonzero_bits: NEG.L sets X for a nonzero word, ADDX.L shifts it
 * in, so the first word's bit ends at bit 0. */
    .section .text.__vme_nonzero_bits_strided, "ax"
    .globl __vme_nonzero_bits_strided
__vme_nonzero_bits_strided:
    move.l  %d2, -(%sp)         /* arguments now at 8, 12, 16 */
    movea.l 8(%sp), %a0
    move.l  12(%sp), %d1
    movea.l 16(%sp), %a1
    moveq   #0, %d0
    bra.s   2f
1:  move.l  (%a0), %d2
    suba.l  %a1, %a0
    neg.l   %d2
    addx.l  %d0, %d0
2:  dbra    %d1, 1b
    move.l  (%sp)+, %d2
    rts

/* ---- unsigned remainder (crates/fx::rem_u32) ----
 * u32 __fx_rem_u32(u32 a, u32 b): a % b, 0 for b = 0. The 64-bit dividend form of DIVU.L
 * with a zero high word (the 32-bit form with a remainder register is mis-assembled,
 * llvm/llvm-project#224186, docs/toolchain.md class 5); the remainder lands in the high
 * word's register. */
    .section .text.__fx_rem_u32, "ax"
    .globl __fx_rem_u32
__fx_rem_u32:
    move.l  %d2, -(%sp)         /* arguments now at 8, 12 */
    move.l  8(%sp), %d0
    move.l  12(%sp), %d1
    moveq   #0, %d2
    tst.l   %d1
    beq.s   1f
    divu.l  %d1, %d2:%d0        /* d2:d0 / d1: d0 = quotient, d2 = remainder */
1:  move.l  %d2, %d0
    move.l  (%sp)+, %d2
    rts

/* ---- record reads: a record's words under its sequence lock (vme-map's
 * GlobalBus::read_words) ----
 * void __vme_read_words(const u32 *src, u32 *dst, u32 n): copies n words in order, each
 * read once. */
    .section .text.__vme_read_words, "ax"
    .globl __vme_read_words
__vme_read_words:
    movea.l 4(%sp), %a0
    movea.l 8(%sp), %a1
    move.l  12(%sp), %d1
    move.l  %d1, %d0            /* eight words a pass, then the 0-7 left by a jump into */
    lsr.l   #3, %d0             /* the last seven moves (records are 4-33 words) */
    beq.s   2f
1:
    .rept   8
    move.l  (%a0)+, (%a1)+
    .endr
    subq.l  #1, %d0
    bne.s   1b
2:  moveq   #7, %d0
    and.l   %d1, %d0
    add.l   %d0, %d0            /* two bytes of code a word */
    neg.l   %d0
    jmp     3f(%pc, %d0.l)
    .rept   7
    move.l  (%a0)+, (%a1)+
    .endr
3:  rts

/* CUP w, t, high, mask, stop: the counter word at (a0) with mask added, unless a byte of it
 * is at 128 or more (high: 0x80808080), then to stop with the word left as it was; a0 on
 * to the next row (512 bytes). CDOWN likewise subtracted, unless a selected byte is 0 or a
 * byte at 128 or more. Uses w and t. The plain word add and subtract of
 * vme_map::layout::counter_fast, for __vme_count_column and __vme_count_run. */
.macro CUP w, t, high, mask, stop
    move.l  (%a0), \w
    move.l  \w, \t
    and.l   \high, \t
    bne.s   \stop
    add.l   \mask, \w
    move.l  \w, (%a0)
    lea     512(%a0), %a0
.endm
.macro CDOWN w, t, high, mask, stop
    move.l  (%a0), \w
    move.l  \w, \t
    and.l   \high, \t
    bne.s   \stop
    move.l  \w, \t
    or.l    \high, \t
    sub.l   \mask, \t
    and.l   \high, \t
    cmp.l   \high, \t
    bne.s   \stop
    sub.l   \mask, \w
    move.l  \w, (%a0)
    lea     512(%a0), %a0
.endm

/* CSEG col, row, left, seg, t: the segment of a column's run from map row `row` (0..127)
 * up to the map's top edge or the run's end, whichever comes first: seg its rows (taken
 * from left, the run's rows not yet placed), a0 at its first pixel (col: the column's
 * pixel in map row 0, rows 512 bytes apart). Uses t, which may be row itself (then
 * row is lost). For __vme_count_column and
 * __vme_count_run, whose runs wrap from row 127 to row 0. */
.macro CSEG col, row, left, seg, t
    move.l  #128, \seg
    sub.l   \row, \seg
    cmp.l   \left, \seg
    bls.s   .Lcseg\@
    move.l  \left, \seg
.Lcseg\@:
    .ifnc \row, \t
    move.l  \row, \t
    .endif
    lsl.l   #8, \t
    add.l   \t, \t
    movea.l \col, %a0
    adda.l  \t, %a0
    sub.l   \seg, \left
.endm

/* ---- C-space column: an image's column as up to five runs (vme-map's
 * GlobalBus::count_column, crates/cspace's raster) ----
 * u32 __vme_count_column(u32 *col, u32 row, const u32 *pieces, u32 skip, u32 down):
 * col points at the column's pixel in map row 0; pieces holds five (rows, mask) pairs taken
 * in order down the column from map row `row` (0..127), rows 512 bytes apart, wrapping from
 * row 127 to row 0. The first `skip` pixels are passed over; each other pixel gets mask
 * added, or subtracted when down, while no byte can carry or borrow
 * (vme_map::layout::counter_fast). Stops before the first pixel that needs the
 * byte-by-byte update; returns its
 * index from the column's first pixel (skip included), or the column's pixel count.
 * Bit-identical to the trait's default loop. */
    .section .text.__vme_count_column, "ax"
    .globl __vme_count_column
__vme_count_column:
    movem.l %d2-%d7/%a2-%a4, -(%sp) /* 9 registers: arguments at 40, 44, 48, 52, 56 */
    movea.l 40(%sp), %a2        /* column, map row 0 */
    move.l  44(%sp), %d7        /* row of the next pixel */
    movea.l 48(%sp), %a3        /* pieces */
    move.l  52(%sp), %d6        /* pixels still to pass over */
    movea.l 56(%sp), %a1        /* down */
    lea     40(%a3), %a4        /* end of the pieces */
    moveq   #0, %d0             /* index of the next pixel */
    move.l  #0x80808080, %d3
    moveq   #0, %d1             /* rows left of the current piece */
1:  cmpa.l  %a4, %a3            /* next piece */
    beq.w   9f
    move.l  (%a3)+, %d1
    move.l  (%a3)+, %d2
    tst.l   %d6
    beq.s   3f
    cmp.l   %d6, %d1
    bhi.s   2f
    add.l   %d1, %d0            /* the whole piece passed over */
    add.l   %d1, %d7
    sub.l   %d1, %d6
    moveq   #127, %d4
    and.l   %d4, %d7
    bra.s   1b
2:  add.l   %d6, %d0            /* part of it */
    add.l   %d6, %d7
    sub.l   %d6, %d1
    moveq   #0, %d6
    moveq   #127, %d4
    and.l   %d4, %d7
3:  tst.l   %d1                 /* a segment: rows up to the map's top edge */
    beq.s   1b
    CSEG    %a2, %d7, %d1, %d4, %d5 /* d4 = rows in this segment */
    add.l   %d4, %d7
    moveq   #127, %d5
    and.l   %d5, %d7
    move.l  %a1, %d5
    tst.l   %d5
    bne.s   6f
5:  CUP     %d5, %d6, %d3, %d2, 9f
    addq.l  #1, %d0
    subq.l  #1, %d4
    bne.s   5b
    moveq   #0, %d6
    bra.s   3b
6:  CDOWN   %d5, %d6, %d3, %d2, 8f
    addq.l  #1, %d0
    subq.l  #1, %d4
    bne.s   6b
    moveq   #0, %d6
    bra.s   3b
8:
9:  movem.l (%sp)+, %d2-%d7/%a2-%a4
    rts

/* ---- C-space run: one run of an image's column (vme-map's GlobalBus::count_run,
 * crates/cspace's raster: a pair's differences) ----
 * u32 __vme_count_run(u32 *col, u32 row, u32 rows, u32 mask, u32 down): col points at the
 * column's pixel in map row 0; from map row `row` (taken mod 128) up, rows 512 bytes apart,
 * wrapping from row 127 to row 0, each of `rows` pixels gets mask added, or subtracted when
 * down, while no byte can carry or borrow (vme_map::layout::counter_fast). Stops before the
 * first pixel that needs the byte-by-byte update; returns how many it updated (`rows` when
 * all). A small move's differences are runs of a row or two: __vme_count_column's five
 * pieces cost ten times the pixel. Bit-identical to the trait's default loop. */
    .section .text.__vme_count_run, "ax"
    .globl __vme_count_run
__vme_count_run:
    movem.l %d2-%d6, -(%sp)         /* 20 bytes: arguments from 24(%sp) */
    movea.l 24(%sp), %a1            /* column, map row 0 */
    move.l  28(%sp), %d1            /* row of the next pixel */
    move.l  32(%sp), %d2            /* rows left */
    move.l  36(%sp), %d3            /* mask */
    move.l  #0x80808080, %d4
    moveq   #0, %d0                 /* pixels updated */
    moveq   #127, %d5
    and.l   %d5, %d1
1:  tst.l   %d2                     /* a segment: rows up to the map's top edge */
    beq.s   9f
    CSEG    %a1, %d1, %d2, %d6, %d1 /* d6 = rows in this segment */
    subq.l  #1, %d6                 /* DBRA's count */
    tst.l   40(%sp)
    bne.s   5f
3:  CUP     %d5, %d1, %d4, %d3, 9f  /* up */
    addq.l  #1, %d0
    dbra    %d6, 3b
    moveq   #0, %d1                 /* the next segment from row 0 */
    bra.s   1b
5:  CDOWN   %d5, %d1, %d4, %d3, 9f  /* down */
    addq.l  #1, %d0
    dbra    %d6, 5b
    moveq   #0, %d1
    bra.s   1b
9:  movem.l (%sp)+, %d2-%d6
    rts

/* ---- fixed-point multiply: the servo's only wide arithmetic (crates/fx) ----
 * i32 __fx_mul_shr(i32 a, i32 b, u32 sh), 1 <= sh <= 32:
 *   round((a * b) >> sh), saturated to i32: the 64-bit product of MULS.L, plus 1 << (sh-1),
 *   arithmetic shift right. Bit-identical to the host version in crates/fx/src/lib.rs. */
/* i32 __fx_div(i32 num, i32 den, u32 sh), 0 <= sh <= 31:
 *   (num * 2^sh) / den truncated toward zero, saturated to i32; den = 0 gives i32::MAX for
 *   num >= 0 and i32::MIN otherwise. DIVS.L divides the 64-bit dividend in two registers.
 *   Bit-identical to the host version in crates/fx/src/lib.rs. */
    .section .text.__fx_div, "ax"
    .globl __fx_div
__fx_div:
    movem.l %d2-%d3, -(%sp)     /* arguments now at 12, 16, 20 */
    move.l  12(%sp), %d0        /* num */
    move.l  20(%sp), %d2        /* sh */
    move.l  %d0, %d1
    moveq   #32, %d3
    sub.l   %d2, %d3
    asr.l   %d3, %d1            /* high word: num >> (32 - sh), all sign bits when sh = 0 */
    lsl.l   %d2, %d0            /* low word: num << sh */
    move.l  16(%sp), %d3        /* den */
    tst.l   %d3
    beq.s   2f
    divs.l  %d3, %d1:%d0        /* d0 = quotient, d1 = remainder */
    bvc.s   3f
    move.l  12(%sp), %d0        /* overflow: saturate toward the quotient's sign */
    eor.l   %d3, %d0
    bra.s   4f
2:  move.l  12(%sp), %d0        /* division by zero: saturate toward num's sign */
4:  tst.l   %d0
    bmi.s   5f
    move.l  #0x7fffffff, %d0
    bra.s   3f
5:  move.l  #0x80000000, %d0
3:  movem.l (%sp)+, %d2-%d3
    rts

/* __fx_sqrt_q16 is in servo.S, beside the servo's law, which takes its square root inline. */

    .section .text.__fx_mul_shr, "ax"
    .globl __fx_mul_shr
__fx_mul_shr:
    movem.l %d2-%d3, -(%sp)     /* arguments now at 12, 16, 20 */
    move.l  12(%sp), %d0
    move.l  16(%sp), %d1
    muls.l  %d1, %d1:%d0        /* d1:d0 = a * b */
    move.l  20(%sp), %d2        /* sh */
    moveq   #1, %d3
    subq.l  #1, %d2
    lsl.l   %d2, %d3            /* 1 << (sh - 1) */
    addq.l  #1, %d2
    add.l   %d3, %d0
    moveq   #0, %d3
    addx.l  %d3, %d1            /* d1:d0 += rounding */
    movea.l %d2, %a0            /* keep sh */
    lsr.l   %d2, %d0            /* low >>= sh (sh = 32 gives 0) */
    move.l  %d1, %d3
    neg.l   %d2
    add.l   #32, %d2            /* 32 - sh */
    lsl.l   %d2, %d3            /* high << (32 - sh) */
    or.l    %d3, %d0            /* low word of the result */
    move.l  %a0, %d2
    asr.l   %d2, %d1            /* high word of the result */
    move.l  %d0, %d3
    moveq   #31, %d2
    asr.l   %d2, %d3            /* sign extension of the low word */
    cmp.l   %d3, %d1
    beq.s   1f                  /* fits in 32 bits */
    move.l  #0x7fffffff, %d0
    tst.l   %d1
    bpl.s   1f
    move.l  #0x80000000, %d0
1:  movem.l (%sp)+, %d2-%d3
    rts

/* ---- the sensing board's position filter (crates/sensing::filter::Filter::push_estimate) ----
 * u32 __sense_filter(Filter *f, i32 qx, i32 qy, u32 adaptive, Estimate *out,
 *                    const i32 *recip_q16):
 * Filter::push of the sample (qx, qy) (Q2 codes) then Filter::estimate, bit-identical to
 * the host's pair; returns 1 with *out written, or 0 (fewer than MIN_VALID samples, *out
 * untouched). recip_q16[n] = 2^16 / n. The means since rest that the movement check takes
 * are the long window's estimate when no movement is found (same sums, same n): computed
 * once. Field offsets: crates/sensing/src/filter.rs `layout` (asserted there). */
    .set    F_SHORT, 512            /* Axis::short (x; y is 520 bytes on) */
    .set    F_SINCE, 516            /* Axis::since */
    .set    F_Y, 520                /* the second axis */
    .set    F_NEXT, 1040            /* u8 ring index */
    .set    F_COUNT, 1042           /* u16 samples held */
    .set    F_SINCE_N, 1044         /* u16 samples since rest */
    .set    F_MOVED, 1046           /* u16 samples since the last movement */
/* FILTER a: the body of __sense_filter with its six arguments at a(%sp) on (f, qx, qy,
 * adaptive, out, recip); ends with d0 = 1 (estimate written) or 0 at its label 41. Uses
 * d0-d7, a0-a2. Also expanded in place by __sense_process (no call, no second save). */
.macro FILTER a
    movea.l \a+0(%sp), %a0
    movea.l \a+20(%sp), %a1
    moveq   #0, %d0
    move.b  F_NEXT(%a0), %d0        /* next */
    moveq   #0, %d1
    move.b  %d0, %d1
    subi.b  #32, %d1                /* (next - SHORT) mod 256 */
    add.l   %d0, %d0                /* byte offsets into the i16 rings */
    add.l   %d1, %d1
    cmpi.w  #32, F_COUNT(%a0)
    scc     %d2                     /* -1: the short window was full (count >= SHORT) */
    extb.l  %d2
    cmpi.w  #256, F_SINCE_N(%a0)
    scc     %d3                     /* -1: the window since rest was full (since >= LONG) */
    extb.l  %d3
    movea.l %a0, %a2                /* axis x, then axis y */
    move.l  \a+4(%sp), %d4
    moveq   #1, %d7
1:  move.w  (%a2,%d1.l), %d5        /* the sample leaving the short window */
    ext.l   %d5
    and.l   %d2, %d5
    move.l  %d4, %d6
    sub.l   %d5, %d6
    add.l   %d6, F_SHORT(%a2)
    move.w  (%a2,%d0.l), %d5        /* the sample leaving the window since rest */
    ext.l   %d5
    and.l   %d3, %d5
    move.l  %d4, %d6
    sub.l   %d5, %d6
    add.l   %d6, F_SINCE(%a2)
    move.w  %d4, (%a2,%d0.l)        /* ring[next] = v as i16 */
    lea     F_Y(%a2), %a2
    move.l  \a+8(%sp), %d4
    dbra    %d7, 1b
    addq.b  #1, F_NEXT(%a0)         /* next wraps at 256 */
    cmpi.w  #256, F_COUNT(%a0)
    bcc.s   2f
    addq.w  #1, F_COUNT(%a0)
2:  moveq   #0, %d5
    move.w  F_SINCE_N(%a0), %d5
    cmpi.w  #256, %d5
    bcc.s   3f
    addq.w  #1, %d5
    move.w  %d5, F_SINCE_N(%a0)     /* d5 = since, from here on the window's length */
3:  move.w  F_MOVED(%a0), %d6
    addq.w  #1, %d6
    bcc.s   4f
    subq.w  #1, %d6                 /* saturates at 0xFFFF */
4:  move.w  %d6, F_MOVED(%a0)
    tst.l   \a+12(%sp)
    beq.w   20f                     /* not adaptive: no movement check, the short window */
    cmpi.w  #32, %d5
    bls.w   20f                     /* since <= SHORT: the short window */
    /* movement check: |short mean - mean since rest| > MOVE_Q5 (896) on either axis */
    move.l  F_SINCE(%a0), %d0
    asr.l   #3, %d0
    move.l  F_Y+F_SINCE(%a0), %d1
    asr.l   #3, %d1
    cmpi.w  #256, %d5
    bne.s   8f
    /* the window full (a resting beacon, the common case): 2^16 / 256 is 2^8, so the
     * product and its shift are a shift down 2 (|sum >> 3| < 2^18: no product overflowed) */
    asr.l   #2, %d0                 /* x mean since rest, Q5 */
    asr.l   #2, %d1                 /* y */
    bra.s   9f
8:  move.l  (%a1,%d5.l*4), %d6      /* 2^16 / since */
    moveq   #10, %d7
    muls.l  %d6, %d0
    asr.l   %d7, %d0                /* x mean since rest, Q5 */
    muls.l  %d6, %d1
    asr.l   %d7, %d1                /* y */
9:  move.l  F_SHORT(%a0), %d2
    asr.l   #2, %d2
    sub.l   %d0, %d2
    bpl.s   5f
    neg.l   %d2
5:  cmpi.l  #896, %d2
    bgt.s   7f
    move.l  F_Y+F_SHORT(%a0), %d2
    asr.l   #2, %d2
    sub.l   %d1, %d2
    bpl.s   6f
    neg.l   %d2
6:  cmpi.l  #896, %d2
    bgt.s   7f
    /* no movement now, but one within MOVING_HOLD samples: the short window still */
    cmpi.w  #128, F_MOVED(%a0)      /* sensing::filter::MOVING_HOLD */
    bcs.w   20f
    /* at rest: the long window, d0/d1 its means, d5 its length */
    cmpi.w  #8, F_COUNT(%a0)
    bcs.w   40f
    movea.l \a+16(%sp), %a2
    bra.s   30f
7:  move.l  F_SHORT(%a0), F_SINCE(%a0)     /* moved: restart the long window from the short */
    move.l  F_Y+F_SHORT(%a0), F_Y+F_SINCE(%a0)
    move.w  #32, F_SINCE_N(%a0)
    clr.w   F_MOVED(%a0)
    /* the short window: min(count, SHORT) samples */
20: moveq   #0, %d4
    move.w  F_COUNT(%a0), %d4
    cmpi.w  #8, %d4
    bcs.s   40f                     /* fewer than MIN_VALID: no estimate */
    movea.l \a+16(%sp), %a2
    moveq   #32, %d5
    move.l  F_SHORT(%a0), %d0
    asr.l   #2, %d0
    move.l  F_Y+F_SHORT(%a0), %d1
    asr.l   #2, %d1
    cmp.l   %d5, %d4
    bcc.s   30f                     /* full: the sum of 32 Q2 samples is the Q5 mean */
    move.l  %d4, %d5                /* filling: sum x 2^16 / n, shifted down 11 */
    move.l  (%a1,%d5.l*4), %d6
    moveq   #11, %d7
    muls.l  %d6, %d0
    asr.l   %d7, %d0
    muls.l  %d6, %d1
    asr.l   %d7, %d1
30: move.l  %d0, (%a2)              /* q5 */
    move.l  %d1, 4(%a2)
    move.l  %d5, %d6                /* samples: the window, at most 255 */
    cmpi.l  #255, %d6
    bls.s   31f
    move.l  #255, %d6
31: move.w  %d6, 8(%a2)
    moveq   #0, %d6                 /* moving: adaptive and moved < SHORT */
    moveq   #0, %d7                 /* filling: window < (adaptive ? LONG : SHORT) */
    tst.l   \a+12(%sp)
    beq.s   32f
    cmpi.w  #128, F_MOVED(%a0)      /* sensing::filter::MOVING_HOLD */
    scs     %d6
    cmpi.l  #256, %d5
    scs     %d7
    bra.s   33f
32: moveq   #32, %d0
    cmp.l   %d0, %d5
    scs     %d7
33: neg.b   %d6
    neg.b   %d7
    move.b  %d6, 10(%a2)
    move.b  %d7, 11(%a2)
    moveq   #1, %d0
    bra.s   41f
40: moveq   #0, %d0
41:
.endm

    .section .text.__sense_filter, "ax"
    .globl __sense_filter
__sense_filter:
    movem.l %d2-%d7/%a2, -(%sp)     /* arguments now at 32: f, qx, qy, adaptive, out, recip */
    FILTER  32
    movem.l (%sp)+, %d2-%d7/%a2
    rts

/* ---- the sensing board's calibrated position (crates/sensing: locate_um) ----
 * u32 __sense_locate(const i32 *inv, i32 vx, i32 vy, const Drift *drift, const i32 area[4],
 *                    i32 out[2]):
 * the drift removed from the filtered signals (vx, vy) (Q5 codes) when drift is not null
 * (Drift::correct), then the bilinear blend of the inverse grid's cell (cal::position_um;
 * inv is the grid's first word: rows of 65 (x, y) pairs, 64 cells of 2^11 Q5 codes a side),
 * written to out (micrometres); returns 1 when the position lies outside area (x min,
 * x max, y min, y max) by more than sensing::AREA_MARGIN_UM, else 0. Bit-identical to the
 * Rust (tests/tests/firmware_functions.rs). Drift offsets: crates/sensing/src/drift.rs
 * `layout` (asserted there). */
    .set    D_O_Q13, 0              /* Drift::o_q13 (x, y) */
    .set    D_K_Q14, 20             /* Drift::k_q14 (x, y): 1 / (1 + g), Q14 */
    .set    AREA_MARGIN_UM, 5000    /* sensing::AREA_MARGIN_UM */
    .set    INV_ROW, 520            /* bytes of an inverse grid row: 2 * INV_N words */
    .set    INV_TOP, 131071         /* (64 << 11) - 1: the grid's last Q5 signal */

/* CORRECT v, o, k: v = Drift's correct_axis(v, o, k) = ((v - (o >> 8)) k) >> 14, the
 * product as i32 (wrapping); d2 scratch. */
.macro CORRECT v, o, k
    move.l  \o, %d2
    asr.l   #8, %d2
    sub.l   %d2, \v
    muls.l  \k, \v
    moveq   #14, %d2
    asr.l   %d2, \v
.endm

/* INVCELL v, f: v = the inverse cell's index of signal v, f its Q10 fraction (cal's
 * inv_cell: v + 2^16 clamped to 0..INV_TOP, then >> 11 and (& 2047) >> 1). */
.macro INVCELL v, f
    addi.l  #65536, \v
    bpl.s   .Lic\@
    moveq   #0, \v
.Lic\@:
    cmpi.l  #INV_TOP, \v
    ble.s   .Lit\@
    move.l  #INV_TOP, \v
.Lit\@:
    move.l  \v, \f
    andi.l  #2047, \f
    lsr.l   #1, \f
    lsr.l   #8, \v
    lsr.l   #3, \v
.endm

/* BILIN off, r, mul: r = cal's bilinear blend of the cell at a0, word offset off (0: x,
 * 4: y); d2 = fx, d3 = fy (Q10), d7 = 10; d0, d6 scratch. Products and sums as i32; mul is
 * the multiply: muls.l for any table, muls.w (27 cycles, not 45) for one whose steps between
 * neighbouring nodes fit a word (cal::Checker::word_steps_mask: then v1 - v0, v3 - v2 and b - a,
 * which lies between v2 - v0 and v3 - v1, all do). */
.macro BILIN off, r, mul
    move.l  \off(%a0), %d0          /* v0 */
    move.l  8+\off(%a0), %d6        /* v1 */
    sub.l   %d0, %d6
    \mul   %d2, %d6
    asr.l   %d7, %d6
    add.l   %d0, %d6                /* a = v0 + ((v1 - v0) fx >> 10) */
    move.l  INV_ROW+\off(%a0), %d0  /* v2 */
    move.l  INV_ROW+8+\off(%a0), \r /* v3 */
    sub.l   %d0, \r
    \mul   %d2, \r
    asr.l   %d7, \r
    add.l   %d0, \r                 /* b = v2 + ((v3 - v2) fx >> 10) */
    sub.l   %d6, \r
    \mul   %d3, \r
    asr.l   %d7, \r
    add.l   %d6, \r                 /* a + ((b - a) fy >> 10) */
.endm

/* LOCATE a, mul: the body of __sense_locate with its six arguments at a(%sp) on (inv, vx,
 * vy, drift, area, out), BILIN's products by mul; ends with d0 = 1 (outside the area) or 0.
 * Uses d0-d7, a0. Also expanded in place by __sense_process, with muls.w. */
.macro LOCATE a, mul
    move.l  \a+4(%sp), %d0            /* vx */
    move.l  \a+8(%sp), %d1            /* vy */
    movea.l \a+12(%sp), %a0            /* drift */
    cmpa.w  #0, %a0
    beq.s   1f
    CORRECT %d0, D_O_Q13(%a0), D_K_Q14(%a0)
    CORRECT %d1, D_O_Q13+4(%a0), D_K_Q14+4(%a0)
1:  INVCELL %d0, %d2                /* i, fx */
    INVCELL %d1, %d3                /* j, fy */
    movea.l \a+0(%sp), %a0            /* the cell: inv + j * INV_ROW + i * 8 */
    move.l  %d1, %d4
    lsl.l   #8, %d4
    add.l   %d4, %d4                /* j * 512 */
    lsl.l   #3, %d1
    add.l   %d4, %d1                /* j * 520 */
    adda.l  %d1, %a0
    lsl.l   #3, %d0
    adda.l  %d0, %a0
    moveq   #10, %d7
    BILIN   0, %d4, \mul            /* x */
    BILIN   4, %d5, \mul            /* y */
    movea.l \a+20(%sp), %a0            /* out */
    move.l  %d4, (%a0)
    move.l  %d5, 4(%a0)
    movea.l \a+16(%sp), %a0            /* area: outside when any side's margin is negative */
    move.l  %d4, %d0
    sub.l   (%a0), %d0
    addi.l  #AREA_MARGIN_UM, %d0    /* x - (x min - margin) */
    move.l  4(%a0), %d1
    addi.l  #AREA_MARGIN_UM, %d1
    sub.l   %d4, %d1                /* (x max + margin) - x */
    or.l    %d1, %d0
    move.l  %d5, %d1
    sub.l   8(%a0), %d1
    addi.l  #AREA_MARGIN_UM, %d1    /* y - (y min - margin) */
    or.l    %d1, %d0
    move.l  12(%a0), %d1
    addi.l  #AREA_MARGIN_UM, %d1
    sub.l   %d5, %d1                /* (y max + margin) - y */
    or.l    %d1, %d0
    moveq   #31, %d1
    lsr.l   %d1, %d0                /* 1 when negative */
.endm

    .section .text.__sense_locate, "ax"
    .globl __sense_locate
__sense_locate:
    movem.l %d2-%d7, -(%sp)         /* arguments now at 28: inv, vx, vy, drift, area, out */
    LOCATE  28, muls.l
    movem.l (%sp)+, %d2-%d7
    rts

/* ---- the sensing board's LED current feedback (crates/sensing: feedback_ma) ----
 * i32 __sense_feedback(i32 level, i32 sum, i32 s_ref): level s_ref / max(sum, 1) (products
 * and quotient as i32, the quotient toward zero; a sum of i32::MIN stays), clamped to
 * LEVEL_MIN..LEVEL_MAX mA by the signs of the wrapped differences, as the Rust.
 * Bit-identical (tests/tests/firmware_functions.rs). */
    .set    LEVEL_MIN, 50           /* sensing::LEVEL_MIN_MA */
    .set    LEVEL_MAX, 1000         /* sensing::LEVEL_MAX_MA (the driver's maximum) */
/* d0 clamped to LEVEL_MIN..LEVEL_MAX by the signs of the wrapped differences (d1 used):
 * here and in __sense_process */
.macro CLAMP_LEVEL
    move.l  %d0, %d1
    subi.l  #LEVEL_MIN, %d1
    bpl.s   201f
    moveq   #LEVEL_MIN, %d0
201: move.l  #LEVEL_MAX, %d1
    sub.l   %d0, %d1
    bpl.s   202f
    move.l  #LEVEL_MAX, %d0
202:
.endm
    .section .text.__sense_feedback, "ax"
    .globl __sense_feedback
__sense_feedback:
    move.l  4(%sp), %d0             /* level */
    muls.l  12(%sp), %d0            /* level s_ref */
    move.l  8(%sp), %d1             /* sum */
    move.l  %d1, %a0
    subq.l  #1, %a0                 /* sum - 1, wrapping (SUBQ to An leaves the flags) */
    cmpa.w  #0, %a0
    bge.s   1f
    moveq   #1, %d1
1:  divs.l  %d1, %d0
    CLAMP_LEVEL
    rts

/* ---- the sensing board's common slot (crates/sensing: Sensing::process) ----
 * u32 __sense_process(Sensing *s, const Conversion *c, const AdcSample *smp, const i32 *inv,
 *                     const i32 *area, Estimate *e, const Tables *t, u32 *const *publish):
 * the processing of one sample when it is the common case: a sum of OCCLUDED_BELOW codes or
 * more, no input over range, a checked table whose node steps fit a word (inv: its inverse
 * grid, null when they do not: cal::Checker::word_steps_mask; area: its calibrated square).
 * Then, as the Rust: the previous sample's record (prev_next, prev_raw), the
 * crosstalk correction, the filter (__sense_filter), the LED feedback (or the fixed level),
 * the raw record, the object record (position by __sense_locate, or filling), the frame
 * counters after beacon 7; then, when publish is not null (publish[0], publish[1]: the
 * sequence words of the object and the raw table in global RAM), the beacon's four words of
 * each table and after beacon 7 their frame words, each under its sequence lock as
 * vme_map's SeqLock::publish_words writes them (Sensing::publish in the Rust). Returns 1
 * with the estimate in *e, 0 without one (filling), or
 * 2 for any other case, with nothing changed (the Rust takes it). Bit-identical to
 * Sensing::process (tests/tests/sensing.rs compares the image with the host slot by slot)
 * for the converter's 12-bit codes and a configuration as Config::from_record or
 * Config::default make it (s_ref 410..2047): the products that fit are 16 x 16 bits.
 * Offsets: crates/sensing/src/lib.rs `layout` (asserted there). */
    .set    S_OBJ_FRAME, 116        /* Sensing::objects.frame */
    .set    S_OBJ_B, 120            /* Sensing::objects.beacons: 16 bytes each */
    .set    S_RAW_FRAME, 248        /* Sensing::raw.frame */
    .set    S_RAW_B, 252            /* Sensing::raw.beacons: 16 bytes each */
    .set    S_DRIFT, 88             /* Sensing::drift (observations 16 bytes on) */
    .set    S_OPT, 0                /* Sensing::config.options (u32) */
    .set    S_SREF, 4               /* Sensing::config.s_ref_codes */
    .set    S_LEVEL, 8              /* Sensing::config.level_ma */
    .set    S_PREV_RAW, 12          /* Sensing::prev_raw (x, y) */
    .set    S_LEVELS, 20            /* Sensing::levels: u16 each */
    .set    S_PREV_NEXT, 36         /* Sensing::prev_next (u8) */
    .set    S_FILTERS, 380          /* Sensing::filters: 1048 bytes a beacon */
    .set    T_XTALK, 1028           /* Tables::crosstalk_q16 */
    .set    T_FB_RECIP, 1156        /* Tables::feedback_recip */
    .set    FILTER_BYTES, 1048      /* sensing::filter::layout::FILTER_BYTES */
/* SEQ_ODD seq: d0 = the sequence word at (seq) made odd, (s | 1) + ((s & 1) << 1) as
 * SeqLock::publish_words makes it, and written back; d2 used. */
.macro SEQ_ODD seq
    move.l  (\seq), %d0
    moveq   #1, %d2
    and.l   %d0, %d2
    add.l   %d2, %d2
    ori.b   #1, %d0
    add.l   %d2, %d0
    move.l  %d0, (\seq)
.endm
/* PUBLISH4 seq, src: the four words at src (advanced past them) to the table whose
 * sequence word is at seq, from its record's word 1 + d1 / 4 on (d1 = 16 x the beacon;
 * word 0 is the frame), under the lock; d0, d2, a1 used. */
.macro PUBLISH4 seq, src
    SEQ_ODD \seq
    lea     8(\seq,%d1.l), %a1         /* past the sequence and frame words */
    move.l  (\src)+, (%a1)+
    move.l  (\src)+, (%a1)+
    move.l  (\src)+, (%a1)+
    move.l  (\src)+, (%a1)+
    addq.l  #1, %d0
    move.l  %d0, (\seq)
.endm
/* PUBLISH1 seq, word: the word to the record's word 0 (the frame) of the table at seq,
 * under the lock. */
.macro PUBLISH1 seq, word
    SEQ_ODD \seq
    move.l  \word, 4(\seq)
    addq.l  #1, %d0
    move.l  %d0, (\seq)
.endm
    .section .text.__sense_process, "ax"
    .globl __sense_process
__sense_process:
    /* the rare cases first, before any register is saved (they leave for the Rust) */
    tst.l   16(%sp)
    beq.w   90f                     /* no grid: the table's steps do not fit a word */
    movea.l 12(%sp), %a0            /* smp */
    tst.b   6(%a0)
    bne.w   90f                     /* over range: the Rust */
    moveq   #0, %d0
    move.w  4(%a0), %d0
    cmpi.l  #2048+205, %d0          /* sensing::OCCLUDED_BELOW_CODES above 0 V */
    blt.w   90f                     /* occluded: the Rust */
    cmpi.w  #4095, %d0
    bhi.w   90f                     /* not a 12-bit code (FEEDBACK_RECIP's range): the Rust */
    movem.l %d2-%d7/%a2-%a5, -(%sp) /* arguments now at 44: s, c, smp, inv, area, e, t */
    move.l  %d0, %d6
    subi.l  #2048, %d6              /* sum, codes above 0 V */
    moveq   #0, %d4
    move.w  (%a0), %d4
    subi.l  #2048, %d4              /* raw x */
    moveq   #0, %d5
    move.w  2(%a0), %d5
    subi.l  #2048, %d5              /* raw y */
    movea.l 44(%sp), %a5            /* s */
    movea.l 48(%sp), %a3            /* c */
    moveq   #0, %d7
    move.b  6(%a3), %d7             /* the beacon */
    move.b  S_PREV_NEXT(%a5), %d0   /* the beacon lit after the previous sample's */
    move.l  S_PREV_RAW(%a5), %d1
    move.l  S_PREV_RAW+4(%a5), %d2
    move.l  %d4, S_PREV_RAW(%a5)
    move.l  %d5, S_PREV_RAW+4(%a5)
    move.b  %d7, %d3
    addq.b  #1, %d3
    andi.b  #7, %d3
    move.b  %d3, S_PREV_NEXT(%a5)
    /* crosstalk: q2 = raw << 2, plus ((raw - prev) f) >> 14 when on and consecutive */
    sub.l   %d4, %d1                /* prev - raw, negated below */
    sub.l   %d5, %d2
    lsl.l   #2, %d4
    lsl.l   #2, %d5
    cmp.b   %d7, %d0
    bne.s   1f
    btst    #3, S_OPT+3(%a5)        /* sensing_options::CROSSTALK */
    beq.s   1f
    moveq   #0, %d3
    move.w  4(%a3), %d3             /* lit ticks */
    subi.l  #296, %d3               /* (lit - 304 + 8) >> 4, clamped to 0..31 */
    asr.l   #4, %d3
    bpl.s   2f
    moveq   #0, %d3
2:  moveq   #31, %d0
    cmp.l   %d0, %d3
    ble.s   3f
    move.l  %d0, %d3
3:  movea.l 68(%sp), %a0            /* tables */
    move.l  T_XTALK(%a0,%d3.l*4), %d3
    neg.l   %d1                     /* raw - prev */
    neg.l   %d2
    muls.w  %d3, %d1                /* 16 x 16 bits: |raw - prev| < 4096 (12-bit codes), */
    muls.w  %d3, %d2                /* the factor at most 1500 */
    moveq   #14, %d3
    asr.l   %d3, %d1
    asr.l   %d3, %d2
    add.l   %d1, %d4
    add.l   %d2, %d5
    /* the filter, in place: FILTER's arguments (f, qx, qy, adaptive, e, recip) pushed */
1:  move.l  %d7, %d0
    mulu.w  #FILTER_BYTES, %d0
    lea     S_FILTERS(%a5,%d0.l), %a4 /* the beacon's filter */
    move.l  %d6, -(%sp)             /* sum, kept */
    move.l  72(%sp), -(%sp)         /* recip: the tables' first (68 + 4) */
    move.l  72(%sp), -(%sp)         /* e (64 + 8) */
    moveq   #0, %d0
    btst    #2, S_OPT+3(%a5)        /* sensing_options::ADAPTIVE_FILTER */
    sne     %d0
    neg.b   %d0
    move.l  %d0, -(%sp)
    move.l  %d5, -(%sp)
    move.l  %d4, -(%sp)
    move.l  %a4, -(%sp)
    FILTER  0
    lea     24(%sp), %sp
    move.l  (%sp)+, %d6             /* sum */
    move.l  %d0, %d3                /* 1: an estimate */
    moveq   #0, %d7
    move.b  6(%a3), %d7             /* the beacon */
    /* the LED feedback: level s_ref / sum clamped, or the fixed level */
    lea     S_LEVELS(%a5,%d7.l*2), %a0
    btst    #0, S_OPT+3(%a5)        /* sensing_options::CURRENT_FEEDBACK */
    bne.s   4f
    move.l  S_LEVEL(%a5), %d0
    bra.s   6f
4:  move.w  (%a0), %d0
    mulu.w  S_SREF+2(%a5), %d0      /* 16 x 16 bits: the level a u16, s_ref in 410..2047 */
    movea.l 68(%sp), %a1            /* tables */
    lea     T_FB_RECIP(%a1), %a1
    mulu.l  (%a1,%d6.l*4), %d1:%d0  /* level s_ref < 2^21, sum in 205..2047: the high */
    move.l  %d1, %d0                /* word is the quotient (sensing::FEEDBACK_RECIP) */
    CLAMP_LEVEL                     /* as __sense_feedback */
6:  move.w  %d0, (%a0)
    /* the raw record */
    move.l  %d7, %d1
    lsl.l   #4, %d1
    lea     S_RAW_B(%a5,%d1.l), %a0
    move.l  %d6, 8(%a0)             /* sum_codes */
    andi.l  #0xffff, %d0
    move.l  %d0, 12(%a0)            /* level_ma */
    lea     S_OBJ_B(%a5,%d1.l), %a2 /* the object record */
    move.l  (%a3), 8(%a2)           /* t_us */
    movea.l 64(%sp), %a1            /* e */
    tst.l   %d3
    beq.w   20f
    move.l  (%a1), (%a0)            /* raw x_q5, y_q5 */
    move.l  4(%a1), 4(%a0)
    /* the position, in place: LOCATE's arguments (inv, x, y, correct ? drift : 0, area,
     * &record) pushed */
    moveq   #0, %d2                 /* correct */
    btst    #1, S_OPT+3(%a5)        /* sensing_options::DRIFT_REFERENCE */
    beq.s   7f
    tst.l   S_DRIFT+16(%a5)
    sne     %d2
    neg.b   %d2
7:  move.l  %d2, -(%sp)             /* correct, kept */
    move.l  %a2, -(%sp)             /* out: x_um, y_um */
    move.l  68(%sp), -(%sp)         /* area (60 + 8) */
    suba.l  %a0, %a0
    tst.l   %d2
    beq.s   8f
    lea     S_DRIFT(%a5), %a0
8:  move.l  %a0, -(%sp)
    move.l  4(%a1), -(%sp)
    move.l  (%a1), -(%sp)
    move.l  80(%sp), -(%sp)         /* inv (56 + 24) */
    LOCATE  0, muls.w               /* the table's steps fit a word: the Rust checked */
    lea     24(%sp), %sp
    move.l  (%sp)+, %d2             /* correct */
    /* flags: VALID, CORRECTED, EXTRAPOLATED, MOVING, FILLING, samples << 8 */
    moveq   #0, %d1
    move.w  8(%a1), %d1
    lsl.l   #8, %d1
    addq.l  #1, %d1                 /* VALID */
    lsl.l   #3, %d2
    or.l    %d2, %d1                /* CORRECTED */
    lsl.l   #5, %d0
    or.l    %d0, %d1                /* EXTRAPOLATED */
    tst.b   10(%a1)
    beq.s   9f
    ori.l   #128, %d1               /* MOVING */
9:  tst.b   11(%a1)
    beq.s   10f
    ori.l   #64, %d1                /* FILLING */
10: moveq   #1, %d3                 /* an estimate (LOCATE used d3) */
    moveq   #0, %d7
    move.b  6(%a3), %d7             /* the beacon */
    bra.s   21f
    /* no estimate yet: FILLING and the samples held */
20: moveq   #0, %d1
    move.w  F_COUNT(%a4), %d1       /* the filter's samples */
    lsl.l   #8, %d1
    ori.l   #64, %d1                /* FILLING */
21: move.l  %d1, 12(%a2)
    cmpi.b  #7, %d7
    bne.s   22f
    addq.l  #1, S_OBJ_FRAME(%a5)
    move.l  S_OBJ_FRAME(%a5), S_RAW_FRAME(%a5)
    /* the publication, when asked for: the tables' sequence words at publish */
22: movea.l 72(%sp), %a0            /* publish (44 + 28) */
    cmpa.w  #0, %a0
    beq.w   24f
    movea.l 4(%a0), %a3             /* the raw table's sequence word (c is done with) */
    movea.l (%a0), %a0              /* the object table's */
    move.l  %d7, %d1
    lsl.l   #4, %d1                 /* the beacon's words: 16 bytes a beacon */
    PUBLISH4 %a0, %a2               /* x_um, y_um, t_us, flags */
    lea     S_RAW_B(%a5,%d1.l), %a2
    PUBLISH4 %a3, %a2               /* x_q5, y_q5, sum_codes, level_ma */
    cmpi.b  #7, %d7
    bne.s   24f
    PUBLISH1 %a0, S_OBJ_FRAME(%a5)
    PUBLISH1 %a3, S_RAW_FRAME(%a5)
24: move.l  %d3, %d0
    movem.l (%sp)+, %d2-%d7/%a2-%a5
    rts
90: moveq   #2, %d0
    rts

/* ---- C-space image columns (crates/cspace's raster::columns; thesis ch. IV section 6) ----
 * void __cspace_columns(const Shape *s, i32 c0, i32 c1, Column *out):
 * every column c = c0..=c1 of image s (cspace::Shape, repr(C): theta1[33] at 0, upper[33]
 * at 132, lower[33] at 264, wraps byte at 396) as a raster::Column (repr(C), eight longs:
 * col, first, rows, lower_rows, upper_from, lower_mask, upper_mask, ends) into out[c - c0].
 * Bit-identical to raster::column called for each c in turn (the host's code, which the
 * system tests compare the image with): the chains' extremes over the strip [a, b] of the
 * column, at its edges (each chain evaluated one unit outward, the division truncated)
 * and at the vertices inside it. The column, the strip's right edge and the extremes stay
 * in registers, and one pointer to vertex j reaches its theta1 and both chains' values
 * (the arrays lie 132 bytes apart): ~1,150 cycles a column with the state in the frame,
 * ~1,100 compiled. */
    .section .text.__cspace_columns, "ax"
    .globl __cspace_columns
    .set    CK, 0               /* segment holding the strip's left edge (kept) */
    .set    CET, 4              /* last right edge: t, segment, upper, lower */
    .set    CEK, 8
    .set    CEU, 12
    .set    CEL, 16
    .set    CUA, 20             /* the chains at the strip's left edge */
    .set    CLA, 24
    .set    CLOC, 28            /* locals' bytes */
    .set    CARG, 4 + 40 + CLOC /* the arguments: s, c0, c1, out */
__cspace_columns:
    movem.l %d2-%d7/%a3-%a6, -(%sp)
    lea     -CLOC(%sp), %sp
    movea.l CARG(%sp), %a0      /* theta1; upper at 132, lower at 264 */
    movea.l CARG+12(%sp), %a3   /* out */
    movea.l CARG+4(%sp), %a6    /* c */
    clr.l   CK(%sp)
    move.l  #0x80000000, CET(%sp)
    moveq   #-1, %d0
    move.l  %d0, CEK(%sp)
.Lcol:
    move.l  %a6, %d0
    cmp.l   CARG+8(%sp), %d0
    bgt     .Ldone
    /* a = max(256 c, t[0]) in d1, b = min(256 c + 256, t[32]) in d3 */
    lsl.l   #8, %d0
    move.l  %d0, %d1
    cmp.l   (%a0), %d1
    bge.s   1f
    move.l  (%a0), %d1
1:  move.l  %d0, %d3
    addi.l  #256, %d3
    cmp.l   128(%a0), %d3
    ble.s   1f
    move.l  128(%a0), %d3
    /* while k < 31 && t[k + 1] <= a: k++ */
1:  move.l  CK(%sp), %d0
    moveq   #31, %d2
2:  cmp.l   %d2, %d0
    bge.s   3f
    cmp.l   4(%a0,%d0.l*4), %d1
    blt.s   3f
    addq.l  #1, %d0
    bra.s   2b
3:  move.l  %d0, CK(%sp)
    /* the chains at a: the last column's right edge when it is the same point */
    cmp.l   CET(%sp), %d1
    bne.s   4f
    cmp.l   CEK(%sp), %d0
    bne.s   4f
    move.l  CEU(%sp), %d4
    move.l  CEL(%sp), %d6
    bra.s   5f
4:  bsr     .Lceval2
    move.l  %d0, %d4
    move.l  %d1, %d6
5:  move.l  %d4, CUA(%sp)
    move.l  %d6, CLA(%sp)
    move.l  %d4, %d5            /* umax d4, umin d5, lmax d6, lmin d7 */
    move.l  %d6, %d7
    /* the vertices inside: j from k while t[j + 1] < b (j < 31 follows: b <= t[32]) */
    move.l  CK(%sp), %d0
    lea     4(%a0,%d0.l*4), %a5 /* &t[j + 1] */
6:  cmp.l   (%a5)+, %d3
    ble.s   7f
    move.l  128(%a5), %d1       /* upper[j], j the vertex just passed, one unit outward */
    addq.l  #1, %d1
    cmp.l   %d4, %d1
    ble.s   8f
    move.l  %d1, %d4
8:  cmp.l   %d5, %d1
    bge.s   8f
    move.l  %d1, %d5
8:  move.l  260(%a5), %d1       /* lower[j] */
    subq.l  #1, %d1
    cmp.l   %d6, %d1
    ble.s   8f
    move.l  %d1, %d6
8:  cmp.l   %d7, %d1
    bge.s   6b
    move.l  %d1, %d7
    bra.s   6b
7:  move.l  %a5, %d0            /* j = (&t[j + 2] - t) / 4 - 2 */
    sub.l   %a0, %d0
    asr.l   #2, %d0
    subq.l  #2, %d0
    /* the chains at b, kept as the next column's left edge */
    move.l  %d0, CEK(%sp)
    move.l  %d3, CET(%sp)
    move.l  %d3, %d1
    bsr     .Lceval2
    move.l  %d0, CEU(%sp)
    move.l  %d1, CEL(%sp)
    cmp.l   %d4, %d0
    ble.s   1f
    move.l  %d0, %d4
1:  cmp.l   %d5, %d0
    bge.s   1f
    move.l  %d0, %d5
1:  cmp.l   %d6, %d1
    ble.s   1f
    move.l  %d1, %d6
1:  cmp.l   %d7, %d1
    bge.s   1f
    move.l  %d1, %d7
1:  /* the column: first row, rows, boundary runs, edge normals */
    move.l  %a6, %d2
    andi.l  #127, %d2
    move.l  %d2, (%a3)+         /* col */
    asr.l   #8, %d7             /* first = pix(lmin) */
    move.l  %d7, (%a3)+
    asr.l   #8, %d4             /* rows = clamp(pix(umax) - first + 1, 1, 128) */
    sub.l   %d7, %d4
    addq.l  #1, %d4
    moveq   #1, %d2
    cmp.l   %d2, %d4
    bge.s   1f
    move.l  %d2, %d4
1:  move.l  #128, %d2
    cmp.l   %d2, %d4
    ble.s   1f
    move.l  %d2, %d4
1:  move.l  %d4, (%a3)+
    asr.l   #8, %d6             /* lower_rows = max(pix(lmax) - first + 1, 0) */
    sub.l   %d7, %d6
    addq.l  #1, %d6
    bpl.s   1f
    moveq   #0, %d6
1:  move.l  %d6, (%a3)+
    asr.l   #8, %d5             /* upper_from = max(pix(umin) - first, 0) */
    sub.l   %d7, %d5
    bpl.s   1f
    moveq   #0, %d5
1:  move.l  %d5, (%a3)+
    moveq   #1, %d2             /* lower_mask = M2 | (lb > la: P1, lb < la: M1) */
    cmp.l   CLA(%sp), %d1
    beq.s   2f
    blt.s   1f
    ori.l   #0x01000000, %d2
    bra.s   2f
1:  ori.l   #0x00010000, %d2
2:  move.l  %d2, (%a3)+
    move.l  #0x100, %d2         /* upper_mask = P2 | (ub > ua: M1, ub < ua: P1) */
    cmp.l   CUA(%sp), %d0
    beq.s   2f
    blt.s   1f
    ori.l   #0x00010000, %d2
    bra.s   2f
1:  ori.l   #0x01000000, %d2
2:  move.l  %d2, (%a3)+
    moveq   #0, %d2             /* ends: none when wrapping, M1 at c0, P1 at c1 */
    tst.b   396(%a0)
    bne.s   2f
    move.l  %a6, %d1
    cmp.l   CARG+4(%sp), %d1
    bne.s   1f
    move.l  #0x00010000, %d2
    bra.s   2f
1:  cmp.l   CARG+8(%sp), %d1
    bne.s   2f
    move.l  #0x01000000, %d2
2:  move.l  %d2, (%a3)+
    addq.l  #1, %a6
    bra     .Lcol
.Ldone:
    lea     CLOC(%sp), %sp
    movem.l (%sp)+, %d2-%d7/%a3-%a6
    rts
/* Both chains at t (d1) on segment d0: the upper chain one unit outward in d0, the lower
 * in d1 (a vertical segment gives the upper its larger end, the lower its smaller).
 * Uses d2, a4 and a5. */
.Lceval2:
    lea     (%a0,%d0.l*4), %a5  /* &t[j]: upper[j] at 132, lower[j] at 264 */
    move.l  4(%a5), %d2
    sub.l   (%a5), %d2          /* tb - ta */
    beq.s   5f
    sub.l   (%a5), %d1          /* t - ta */
    move.l  136(%a5), %d0
    sub.l   132(%a5), %d0       /* vb - va */
    muls.l  %d1, %d0
    divs.l  %d2, %d0            /* truncated, as fx::div */
    add.l   132(%a5), %d0
    addq.l  #1, %d0
    movea.l %d0, %a4
    move.l  268(%a5), %d0
    sub.l   264(%a5), %d0
    muls.l  %d1, %d0
    divs.l  %d2, %d0
    add.l   264(%a5), %d0
    subq.l  #1, %d0
    move.l  %d0, %d1
    move.l  %a4, %d0
    rts
5:  move.l  132(%a5), %d0
    move.l  136(%a5), %d1
    cmp.l   %d1, %d0
    bge.s   6f
    move.l  %d1, %d0
6:  addq.l  #1, %d0
    movea.l %d0, %a4
    move.l  264(%a5), %d0
    move.l  268(%a5), %d1
    cmp.l   %d1, %d0
    ble.s   7f
    move.l  %d1, %d0
7:  subq.l  #1, %d0
    move.l  %d0, %d1
    move.l  %a4, %d0
    rts

/* ---- C-space image compare (crates/cspace's raster::same_shape) ----
 * u32 __cspace_same_shape(const Shape *a, const Shape *b): 1 when the two images
 * (cspace::Shape, repr(C): theta1, upper and lower, 33 longs each, from 0; the wraps byte
 * at 396) are the same, else 0; the first vertices first, so that images of other
 * obstacles part at once. */
    .section .text.__cspace_same_shape, "ax"
    .globl __cspace_same_shape
__cspace_same_shape:
    movea.l 4(%sp), %a0
    movea.l 8(%sp), %a1
    moveq   #0, %d0
    move.b  396(%a0), %d1
    cmp.b   396(%a1), %d1
    bne.s   9f
    moveq   #98, %d1            /* 99 longs */
1:  cmpm.l  (%a0)+, (%a1)+
    dbne    %d1, 1b
    bne.s   9f
    moveq   #1, %d0
9:  rts

/* ---- C-space pair walk (crates/cspace's raster::walk; thesis ch. IV section 6) ----
 * u32 __cspace_walk(const Column *old, i32 oc0, i32 oc1, const Column *new, i32 nc0,
 *                   i32 nc1, Rec *out, u32 cap):
 * walks map columns min(oc0, nc0)..=max(oc1, nc1) of an old and a new image (their
 * raster::Column records from oc0 and nc0; an empty range has oc0 > oc1) and writes a
 * raster::Rec (five longs: kind | column << 8, row, rows, up, down) for each thing that
 * differs: a column only the new image has (kind 1, row = its index), only the old one
 * (kind 2), and, in a column both have and that is not the same, each run of rows between
 * the two columns' merged breakpoints whose counters differ (kind 0: row unwrapped, rows,
 * the counters the new adds, those the old drops). Returns the records written, or cap + 1
 * when they do not fit. The same records as the host's walk by cursors, which the system
 * tests compare it with through the map. */
/* WREC col, kind, c0: a record of the whole column whose raster::Column is at (col):
 * kind | column << 8 (1: only the new image has it, 2: only the old), its index in that
 * image's columns (WC less the image's first column, at c0(%a6)), no rows, no counters.
 * To .Lwfull when the records are at the cap. Uses d3. */
.macro WREC col, kind, c0
    cmp.l   36(%a6), %d7
    bcc     .Lwfull
    move.l  (\col), %d3
    lsl.l   #8, %d3
    addq.l  #\kind, %d3
    move.l  %d3, (%a3)+
    move.l  WC(%a6), %d3
    sub.l   \c0(%a6), %d3
    move.l  %d3, (%a3)+
    clr.l   (%a3)+
    clr.l   (%a3)+
    clr.l   (%a3)+
    addq.l  #1, %d7
.endm

/* WRUNS col, bp, shift: column col's rows, moved by shift (whole revolutions of theta2,
 * the same pixels), as breakpoints at bp(%a6) (first, the lower of
 * first + min(lower_rows, rows) and first + min(upper_from, rows), the higher, first +
 * rows, then 0x7fffffff) and its runs' counters 20 bytes on (none before, the lower
 * chain's rows: ends | lower; between: all four, or ends | lower | upper where both chains
 * cross; the upper chain's: ends | upper; none after), all four in a full column (rows
 * 128). What raster::pieces paints, row by row. Uses d0-d6 and a2. */
.macro WRUNS col, bp, shift
    lea     \bp(%a6), %a2
    move.l  4(\col), %d0        /* first, moved by shift rows */
    add.l   \shift, %d0
    move.l  8(\col), %d1        /* rows */
    move.l  %d0, (%a2)
    move.l  12(\col), %d2       /* min(lower_rows, rows) */
    cmp.l   %d1, %d2
    bls.s   1f
    move.l  %d1, %d2
1:  move.l  16(\col), %d3       /* min(upper_from, rows) */
    cmp.l   %d1, %d3
    bls.s   1f
    move.l  %d1, %d3
1:  move.l  28(\col), %d4
    move.l  %d4, %d5
    or.l    20(\col), %d4       /* ends | lower */
    or.l    24(\col), %d5       /* ends | upper */
    move.l  #0x01010101, %d6    /* the interior */
    cmp.l   %d3, %d2
    bls.s   2f
    exg     %d2, %d3            /* both chains cross the rows between */
    move.l  %d4, %d6
    or.l    24(\col), %d6
2:  cmpi.l  #127, %d1
    bls.s   4f
    move.l  #0x01010101, %d4    /* a full column: all four throughout */
    move.l  %d4, %d5
    move.l  %d4, %d6
4:  add.l   %d0, %d2
    move.l  %d2, 4(%a2)
    add.l   %d0, %d3
    move.l  %d3, 8(%a2)
    add.l   %d1, %d0
    move.l  %d0, 12(%a2)
    move.l  #0x7fffffff, 16(%a2)
    clr.l   20(%a2)
    move.l  %d4, 24(%a2)
    move.l  %d6, 28(%a2)
    move.l  %d5, 32(%a2)
    clr.l   36(%a2)
.endm

/* WEMIT: the rows d0 .. d6 of column (a0), where the old image's counters d5 differ from
 * the new one's d1, as a record (kind 0: up, the new and not the old; down, the old and not
 * the new), or the last record made longer when it ends at d0 (a5) with the same counters.
 * Sets a5 to d6. To .Lwfull when the records are at the cap. Uses d1-d3. */
.macro WEMIT
    move.l  %d5, %d2
    not.l   %d2
    and.l   %d1, %d2            /* up: new and not old */
    not.l   %d1
    and.l   %d5, %d1            /* down: old and not new */
    cmp.l   %a5, %d0
    bne.s   8f
    cmp.l   -8(%a3), %d2
    bne.s   8f
    cmp.l   -4(%a3), %d1
    bne.s   8f
    move.l  %d6, %d3            /* right after the last run, the same counters: longer */
    sub.l   %d0, %d3
    add.l   %d3, -12(%a3)
    bra.s   9f
8:  cmp.l   36(%a6), %d7
    bcc     .Lwfull
    move.l  (%a0), %d3
    lsl.l   #8, %d3             /* kind 0 */
    move.l  %d3, (%a3)+
    move.l  %d0, (%a3)+
    move.l  %d6, %d3
    sub.l   %d0, %d3
    move.l  %d3, (%a3)+
    move.l  %d2, (%a3)+
    move.l  %d1, (%a3)+
    addq.l  #1, %d7
9:  move.l  %d6, %a5
.endm

    .section .text.__cspace_walk, "ax"
    .globl __cspace_walk
    .set    WC, -4              /* column */
    .set    WHI, -8             /* last column */
    .set    WOB, -88            /* the old column's breakpoints (four, then past any row) */
    .set    WOM, -68            /* the counters of its runs: before, three, after */
    .set    WNB, -48            /* the new column's likewise */
    .set    WNM, -28
    .set    WNEAR, 1            /* raster::NEAR_ROWS */
    .set    WSHIFT, 3           /* raster::NEAR_SHIFT */
__cspace_walk:
    link    %a6, #-88
    movem.l %d2-%d7/%a2-%a5, -(%sp)
    move.l  32(%a6), %a3        /* next record */
    moveq   #0, %d7             /* records */
    move.l  12(%a6), %d0        /* lo = min(oc0, nc0) */
    cmp.l   24(%a6), %d0
    ble.s   1f
    move.l  24(%a6), %d0
1:  move.l  %d0, WC(%a6)
    move.l  16(%a6), %d0        /* hi = max(oc1, nc1) */
    cmp.l   28(%a6), %d0
    bge.s   1f
    move.l  28(%a6), %d0
1:  move.l  %d0, WHI(%a6)
.Lwcol:
    move.l  WC(%a6), %d0
    cmp.l   WHI(%a6), %d0
    bgt     .Lwdone
    /* a0: the old image's column (0: none), a1: the new one's */
    sub.l   %a0, %a0
    move.l  %d0, %d1
    sub.l   12(%a6), %d1
    bmi.s   1f
    cmp.l   16(%a6), %d0
    bgt.s   1f
    lsl.l   #5, %d1
    move.l  8(%a6), %a0
    add.l   %d1, %a0
1:  sub.l   %a1, %a1
    move.l  %d0, %d1
    sub.l   24(%a6), %d1
    bmi.s   1f
    cmp.l   28(%a6), %d0
    bgt.s   1f
    lsl.l   #5, %d1
    move.l  20(%a6), %a1
    add.l   %d1, %a1
1:  move.l  %a1, %d1
    tst.l   %d1
    bne.s   2f
    move.l  %a0, %d1            /* the old image's alone, or neither */
    tst.l   %d1
    beq     .Lwnext
    WREC    %a0, 2, 12
    bra     .Lwnext
2:  move.l  %a0, %d1
    tst.l   %d1
    bne.s   4f
    WREC    %a1, 1, 24          /* the new image's alone */
    bra     .Lwnext
4:  /* both: nothing when the columns are the same, or both full (every row all four
     * counters once, whatever their first rows) */
    move.l  %a0, %a2
    move.l  %a1, %a5
    moveq   #7, %d1
5:  cmpm.l  (%a2)+, (%a5)+
    dbne    %d1, 5b
    beq     .Lwnext
    move.l  8(%a0), %d1
    and.l   8(%a1), %d1
    btst    #7, %d1
    bne     .Lwnext
    /* the old column's rows moved by the whole revolutions of theta2 (128 rows: the same
     * pixels) that bring its first row nearest the new one's (a4: images near the elbow's
     * circle lie a revolution apart in some columns after a small move) */
    move.l  4(%a1), %d0
    sub.l   4(%a0), %d0         /* first: new - old */
    move.l  %d0, %d3
    addi.l  #64, %d3
    asr.l   #7, %d3
    lsl.l   #7, %d3
    movea.l %d3, %a4
    sub.l   %d3, %d0
    /* columns whose first or last rows moved by more than WNEAR rows, and together by
     * more than the columns' rows >> WSHIFT, redrawn whole (fewer, longer runs than
     * their difference) */
    move.l  %d0, %d1
    add.l   8(%a1), %d1
    sub.l   8(%a0), %d1         /* last: new - old */
    tst.l   %d0                 /* |first|, |last| */
    bpl.s   1f
    neg.l   %d0
1:  tst.l   %d1
    bpl.s   1f
    neg.l   %d1
1:  moveq   #WNEAR, %d2
    cmp.l   %d2, %d0
    bhi.s   2f
    cmp.l   %d2, %d1
    bls.s   12f                 /* both within WNEAR */
2:  add.l   %d1, %d0
    move.l  8(%a0), %d2
    add.l   8(%a1), %d2
    lsr.l   #WSHIFT, %d2
    cmp.l   %d2, %d0
    bls.s   12f                 /* together within the rows >> WSHIFT */
11: WREC    %a1, 1, 24          /* the new column whole, then the old one */
    WREC    %a0, 2, 12
    bra     .Lwnext
12:
    /* each column's rows as three runs between four breakpoints (raster::pieces's runs:
     * the lower chain's rows, the interior or the rows both chains cross, the upper
     * chain's rows; all four counters throughout a full column), then both columns
     * walked together, breakpoint by breakpoint */
    WRUNS   %a0, WOB, %a4
    WRUNS   %a1, WNB, #0
    /* Columns whose runs keep their counters (most of a small move's): the difference is
     * a run at each breakpoint that moved, between its old and new rows, with the counters
     * of the runs either side of it (as counts, the new column's rows less the old one's
     * are the sum of those runs, each breakpoint's step in counters over the rows it moved
     * across: right also where a breakpoint passes a neighbour's other row, where the
     * walk below would cut the rows differently). */
    move.l  WOM+4(%a6), %d0
    cmp.l   WNM+4(%a6), %d0
    bne.w   20f
    move.l  WOM+8(%a6), %d0
    cmp.l   WNM+8(%a6), %d0
    bne.w   20f
    move.l  WOM+12(%a6), %d0
    cmp.l   WNM+12(%a6), %d0
    bne.w   20f
    lea     WOB(%a6), %a2       /* breakpoint i: the old column's, then its counters' */
    lea     WNB(%a6), %a4       /* run before it 16 bytes on (after the increment) */
    move.l  #0x80000000, %a5
    moveq   #3, %d4
24: move.l  (%a2)+, %d0
    move.l  (%a4)+, %d6
    cmp.l   %d6, %d0
    beq.s   26f
    blt.s   25f
    exg     %d0, %d6            /* new below old: the old column's run before it there */
    move.l  16(%a2), %d5
    move.l  20(%a2), %d1
    bra.s   27f
25: move.l  20(%a2), %d5        /* old below new: the old column's run after it there */
    move.l  16(%a2), %d1
27: cmp.l   %d1, %d5
    beq.s   26f
    WEMIT
26: dbra    %d4, 24b
    bra     .Lwnext
20: lea     WOB(%a6), %a2       /* the old column's next breakpoint; its run's counters */
    lea     WNB(%a6), %a4       /* 20 bytes on; the new column's likewise */
    move.l  (%a2), %d0          /* p: the lower first row */
    cmp.l   (%a4), %d0
    ble.s   1f
    move.l  (%a4), %d0
1:  move.l  #0x80000000, %a5    /* where this column's last run ended (none yet) */
    /* past every breakpoint at or below p */
2:  cmp.l   (%a2), %d0
    blt.s   3f
    addq.l  #4, %a2
    bra.s   2b
3:  cmp.l   (%a4), %d0
    blt.s   4f
    addq.l  #4, %a4
    bra.s   3b
4:  move.l  (%a2), %d6          /* q: the next breakpoint of either */
    cmp.l   (%a4), %d6
    ble.s   5f
    move.l  (%a4), %d6
5:  cmp.l   #0x7fffffff, %d6
    beq     .Lwnext             /* past both columns */
    move.l  20(%a2), %d5        /* old */
    move.l  20(%a4), %d1        /* new */
    cmp.l   %d1, %d5
    beq.s   10f
    WEMIT
10: move.l  %d6, %d0
    bra.s   2b
.Lwnext:
    addq.l  #1, WC(%a6)
    bra     .Lwcol
.Lwfull:
    move.l  36(%a6), %d7
    addq.l  #1, %d7
.Lwdone:
    move.l  %d7, %d0
    movem.l (%sp)+, %d2-%d7/%a2-%a5
    unlk    %a6
    rts

/* ---- C-space image interpolation (crates/cspace's fill; thesis ch. IV section 5) ----
 * void __cspace_fill(Shape *out, const i32 *ua, const i32 *ub, i32 f_q16, i32 half,
 *                    i32 c2, i32 alpha, const i32 *fraction_q15):
 * the image between two database samples: upper[k] = ua[k] + ((ub[k] - ua[k]) f >> 16);
 * theta1[k] = half fraction[k] >> 15 for k = 16..32, mirrored negative into 32 - k (in that
 * order, as the Rust); lower[k] = 2 c2 - upper[32 - k]; then alpha added to all 99 words.
 * (`wraps` is the caller's.) Bit-identical to the host's `fill`, which the system tests
 * compare it with through the image probe; the compiled loops spent ~10,000 cycles an
 * image. */
    .section .text.__cspace_fill, "ax"
    .globl __cspace_fill
__cspace_fill:
    link    %a6, #0
    movem.l %d2-%d7/%a2-%a3, -(%sp)
    move.l  8(%a6), %a0         /* theta1; upper at +132, lower at +264 */
    move.l  12(%a6), %a1        /* ua */
    move.l  16(%a6), %a2        /* ub */
    move.l  20(%a6), %d7        /* f */
    lea     132(%a0), %a3
    moveq   #16, %d2
    moveq   #32, %d6
1:  move.l  (%a2)+, %d0
    move.l  (%a1)+, %d1
    sub.l   %d1, %d0
    muls.l  %d7, %d0
    asr.l   %d2, %d0
    add.l   %d1, %d0
    move.l  %d0, (%a3)+
    dbra    %d6, 1b
    move.l  24(%a6), %d7        /* half */
    move.l  36(%a6), %a1        /* fraction */
    moveq   #15, %d2
    moveq   #16, %d6
2:  move.l  (%a1,%d6.l*4), %d0
    muls.l  %d7, %d0
    asr.l   %d2, %d0
    move.l  %d0, (%a0,%d6.l*4)
    neg.l   %d0
    moveq   #32, %d1
    sub.l   %d6, %d1
    move.l  %d0, (%a0,%d1.l*4)
    addq.l  #1, %d6
    moveq   #33, %d1
    cmp.l   %d1, %d6
    blt.s   2b
    move.l  28(%a6), %d7
    add.l   %d7, %d7            /* 2 c2 */
    lea     132(%a0), %a1
    lea     264(%a0), %a2
    moveq   #0, %d6
3:  moveq   #32, %d1
    sub.l   %d6, %d1
    move.l  %d7, %d0
    sub.l   (%a1,%d1.l*4), %d0
    move.l  %d0, (%a2,%d6.l*4)
    addq.l  #1, %d6
    moveq   #33, %d1
    cmp.l   %d1, %d6
    blt.s   3b
    move.l  32(%a6), %d7        /* alpha */
    move.l  %a0, %a1
    moveq   #98, %d6
4:  add.l   %d7, (%a1)+
    dbra    %d6, 4b
    movem.l (%sp)+, %d2-%d7/%a2-%a3
    unlk    %a6
    rts
