/*
 * sobol.h — Sobol' points in 8 dimensions with hash-based nested uniform
 * (Owen) scrambling.
 *
 * Direction numbers: dimension 0 is van der Corput (m_k = 1); dimensions
 * 1..7 are Joe & Kuo's "new-joe-kuo-6.21201" rows d = 2..8 (S. Joe, F. Y. Kuo,
 * "Constructing Sobol sequences with better two-dimensional projections",
 * SIAM J. Sci. Comput. 30, 2008):
 *     d  s  a  m_1..m_s
 *     2  1  0  1
 *     3  2  1  1 3
 *     4  3  1  1 3 1
 *     5  3  2  1 1 1
 *     6  4  1  1 1 3 3
 *     7  4  4  1 3 5 13
 *     8  5  2  1 1 5 5 17
 * expanded to 32 bits with the Sobol recurrence
 *     m_k = 2 a_1 m_{k-1} ^ 4 a_2 m_{k-2} ^ ... ^ 2^{s-1} a_{s-1} m_{k-s+1}
 *           ^ 2^s m_{k-s} ^ m_{k-s},   V_k = m_k << (32 - k).
 * The lists below (BT_SOBOL_DIRECTIONS_d) are that expansion;
 * tests/test_sampler.cpp re-derives them
 * from the (s, a, m) rows above and compares bt_sobol_v.
 *
 * Scrambling: a true nested uniform scramble.  Digit k (k = 0 most
 * significant) of the point is flipped by one pseudo-random bit drawn from
 * a hash of (seed, the node of the binary tree reached by digits 0..k-1).
 * Every node therefore gets its own independent flip, which is exactly
 * Owen's nested uniform scramble in base 2 (A. B. Owen, "Randomly permuted
 * (t,m,s)-nets and (t,s)-sequences", 1995), so the (t,m,s)-net structure is
 * preserved.  The node is numbered like a heap, (1 << k) | prefix, which is
 * unique across depths.  Only the top BT_SOBOL_SCRAMBLE_BITS digits are
 * scrambled: the rest never reach the returned REAL (24 bits in float mode,
 * 32 in double mode).
 */
#ifndef BRDFTAB_SOBOL_H
#define BRDFTAB_SOBOL_H

#include "compat.h"

#define BT_SOBOL_DIMS 8u

#if defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT && BT_DEVICE
#define BT_SOBOL_SCRAMBLE_BITS 24u
#else
#define BT_SOBOL_SCRAMBLE_BITS 32u
#endif

/* The direction numbers V_k of dimension d (k = 0..31), passed to a macro M:
 * the one list that both tables below are built from. */
#define BT_SOBOL_DIRECTIONS_0(M) \
    M(0x80000000u, 0x40000000u, 0x20000000u, 0x10000000u, 0x08000000u, 0x04000000u, \
      0x02000000u, 0x01000000u, 0x00800000u, 0x00400000u, 0x00200000u, 0x00100000u, \
      0x00080000u, 0x00040000u, 0x00020000u, 0x00010000u, 0x00008000u, 0x00004000u, \
      0x00002000u, 0x00001000u, 0x00000800u, 0x00000400u, 0x00000200u, 0x00000100u, \
      0x00000080u, 0x00000040u, 0x00000020u, 0x00000010u, 0x00000008u, 0x00000004u, \
      0x00000002u, 0x00000001u)
#define BT_SOBOL_DIRECTIONS_1(M) \
    M(0x80000000u, 0xC0000000u, 0xA0000000u, 0xF0000000u, 0x88000000u, 0xCC000000u, \
      0xAA000000u, 0xFF000000u, 0x80800000u, 0xC0C00000u, 0xA0A00000u, 0xF0F00000u, \
      0x88880000u, 0xCCCC0000u, 0xAAAA0000u, 0xFFFF0000u, 0x80008000u, 0xC000C000u, \
      0xA000A000u, 0xF000F000u, 0x88008800u, 0xCC00CC00u, 0xAA00AA00u, 0xFF00FF00u, \
      0x80808080u, 0xC0C0C0C0u, 0xA0A0A0A0u, 0xF0F0F0F0u, 0x88888888u, 0xCCCCCCCCu, \
      0xAAAAAAAAu, 0xFFFFFFFFu)
#define BT_SOBOL_DIRECTIONS_2(M) \
    M(0x80000000u, 0xC0000000u, 0x60000000u, 0x90000000u, 0xE8000000u, 0x5C000000u, \
      0x8E000000u, 0xC5000000u, 0x68800000u, 0x9CC00000u, 0xEE600000u, 0x55900000u, \
      0x80680000u, 0xC09C0000u, 0x60EE0000u, 0x90550000u, 0xE8808000u, 0x5CC0C000u, \
      0x8E606000u, 0xC5909000u, 0x6868E800u, 0x9C9C5C00u, 0xEEEE8E00u, 0x5555C500u, \
      0x8000E880u, 0xC0005CC0u, 0x60008E60u, 0x9000C590u, 0xE8006868u, 0x5C009C9Cu, \
      0x8E00EEEEu, 0xC5005555u)
#define BT_SOBOL_DIRECTIONS_3(M) \
    M(0x80000000u, 0xC0000000u, 0x20000000u, 0x50000000u, 0xF8000000u, 0x74000000u, \
      0xA2000000u, 0x93000000u, 0xD8800000u, 0x25400000u, 0x59E00000u, 0xE6D00000u, \
      0x78080000u, 0xB40C0000u, 0x82020000u, 0xC3050000u, 0x208F8000u, 0x51474000u, \
      0xFBEA2000u, 0x75D93000u, 0xA0858800u, 0x914E5400u, 0xDBE79E00u, 0x25DB6D00u, \
      0x58800080u, 0xE54000C0u, 0x79E00020u, 0xB6D00050u, 0x800800F8u, 0xC00C0074u, \
      0x200200A2u, 0x50050093u)
#define BT_SOBOL_DIRECTIONS_4(M) \
    M(0x80000000u, 0x40000000u, 0x20000000u, 0xB0000000u, 0xF8000000u, 0xDC000000u, \
      0x7A000000u, 0x9D000000u, 0x5A800000u, 0x2FC00000u, 0xA1600000u, 0xF0B00000u, \
      0xDA880000u, 0x6FC40000u, 0x81620000u, 0x40BB0000u, 0x22878000u, 0xB3C9C000u, \
      0xFB65A000u, 0xDDB2D000u, 0x78022800u, 0x9C0B3C00u, 0x5A0FB600u, 0x2D0DDB00u, \
      0xA2878080u, 0xF3C9C040u, 0xDB65A020u, 0x6DB2D0B0u, 0x800228F8u, 0x400B3CDCu, \
      0x200FB67Au, 0xB00DDB9Du)
#define BT_SOBOL_DIRECTIONS_5(M) \
    M(0x80000000u, 0x40000000u, 0x60000000u, 0x30000000u, 0xC8000000u, 0x24000000u, \
      0x56000000u, 0xFB000000u, 0xE0800000u, 0x70400000u, 0xA8600000u, 0x14300000u, \
      0x9EC80000u, 0xDF240000u, 0xB6D60000u, 0x8BBB0000u, 0x48008000u, 0x64004000u, \
      0x36006000u, 0xCB003000u, 0x2880C800u, 0x54402400u, 0xFE605600u, 0xEF30FB00u, \
      0x7E48E080u, 0xAF647040u, 0x1EB6A860u, 0x9F8B1430u, 0xD6C81EC8u, 0xBB249F24u, \
      0x80D6D6D6u, 0x40BBBBBBu)
#define BT_SOBOL_DIRECTIONS_6(M) \
    M(0x80000000u, 0xC0000000u, 0xA0000000u, 0xD0000000u, 0x58000000u, 0x94000000u, \
      0x3E000000u, 0xE3000000u, 0xBE800000u, 0x23C00000u, 0x1E200000u, 0xF3100000u, \
      0x46780000u, 0x67840000u, 0x78460000u, 0x84670000u, 0xC6788000u, 0xA784C000u, \
      0xD846A000u, 0x5467D000u, 0x9E78D800u, 0x33845400u, 0xE6469E00u, 0xB7673300u, \
      0x20F86680u, 0x104477C0u, 0xF8668020u, 0x4477C010u, 0x668020F8u, 0x77C01044u, \
      0x8020F866u, 0xC0104477u)
#define BT_SOBOL_DIRECTIONS_7(M) \
    M(0x80000000u, 0x40000000u, 0xA0000000u, 0x50000000u, 0x88000000u, 0x24000000u, \
      0x12000000u, 0x2D000000u, 0x76800000u, 0x9E400000u, 0x08200000u, 0x64100000u, \
      0xB2280000u, 0x7D140000u, 0xFEA20000u, 0xBA490000u, 0x1A248000u, 0x491B4000u, \
      0xC4B5A000u, 0xE3739000u, 0xF6800800u, 0xDE400400u, 0xA8200A00u, 0x34100500u, \
      0x3A280880u, 0x59140240u, 0xECA20120u, 0x974902D0u, 0x6CA48768u, 0xD75B49E4u, \
      0xCC95A082u, 0x87639641u)

#define BT_SOBOL_ROW(...) {__VA_ARGS__}
BT_TABLE uint bt_sobol_v[BT_SOBOL_DIMS][32] = {
    BT_SOBOL_DIRECTIONS_0(BT_SOBOL_ROW), BT_SOBOL_DIRECTIONS_1(BT_SOBOL_ROW),
    BT_SOBOL_DIRECTIONS_2(BT_SOBOL_ROW), BT_SOBOL_DIRECTIONS_3(BT_SOBOL_ROW),
    BT_SOBOL_DIRECTIONS_4(BT_SOBOL_ROW), BT_SOBOL_DIRECTIONS_5(BT_SOBOL_ROW),
    BT_SOBOL_DIRECTIONS_6(BT_SOBOL_ROW), BT_SOBOL_DIRECTIONS_7(BT_SOBOL_ROW),
};

/* Nibble tables: bt_sobol_nibble[d][j][n] is the XOR of the direction
 * numbers V_{4j+i} of dimension d over the set bits i of n (n = 0..15), i.e.
 * the part of bt_sobol_u32 that bits 4j..4j+3 of the index contribute. */
#define BT_SOBOL_NIBBLE_ROW(a, b, c, d)                                        \
    {0u, (a), (b), (a) ^ (b), (c), (a) ^ (c), (b) ^ (c), (a) ^ (b) ^ (c), (d), \
     (a) ^ (d), (b) ^ (d), (a) ^ (b) ^ (d), (c) ^ (d), (a) ^ (c) ^ (d),        \
     (b) ^ (c) ^ (d), (a) ^ (b) ^ (c) ^ (d)}
#define BT_SOBOL_NIBBLES(v0, v1, v2, v3, v4, v5, v6, v7, v8, v9, v10, v11, v12, \
                         v13, v14, v15, v16, v17, v18, v19, v20, v21, v22, v23, \
                         v24, v25, v26, v27, v28, v29, v30, v31)                 \
    {BT_SOBOL_NIBBLE_ROW(v0, v1, v2, v3), BT_SOBOL_NIBBLE_ROW(v4, v5, v6, v7),    \
     BT_SOBOL_NIBBLE_ROW(v8, v9, v10, v11), BT_SOBOL_NIBBLE_ROW(v12, v13, v14, v15), \
     BT_SOBOL_NIBBLE_ROW(v16, v17, v18, v19), BT_SOBOL_NIBBLE_ROW(v20, v21, v22, v23), \
     BT_SOBOL_NIBBLE_ROW(v24, v25, v26, v27), BT_SOBOL_NIBBLE_ROW(v28, v29, v30, v31)}
BT_TABLE uint bt_sobol_nibble[BT_SOBOL_DIMS][8][16] = {
    BT_SOBOL_DIRECTIONS_0(BT_SOBOL_NIBBLES), BT_SOBOL_DIRECTIONS_1(BT_SOBOL_NIBBLES),
    BT_SOBOL_DIRECTIONS_2(BT_SOBOL_NIBBLES), BT_SOBOL_DIRECTIONS_3(BT_SOBOL_NIBBLES),
    BT_SOBOL_DIRECTIONS_4(BT_SOBOL_NIBBLES), BT_SOBOL_DIRECTIONS_5(BT_SOBOL_NIBBLES),
    BT_SOBOL_DIRECTIONS_6(BT_SOBOL_NIBBLES), BT_SOBOL_DIRECTIONS_7(BT_SOBOL_NIBBLES),
};

/* Fixed-count loops are unrolled on the device, as BT_MATH_UNROLL in
 * bt_math.h (not included here). */
#if BT_DEVICE
#define BT_SOBOL_UNROLL _Pragma("unroll")
#else
#define BT_SOBOL_UNROLL
#endif

/* Unscrambled Sobol' coordinate `dim` of point `index`, as 32 bits
 * (the point is this value / 2^32).  Direct (non-Gray-code) order, so point
 * `index` is a pure function of index: the XOR of V_k over the set bits k of
 * index, taken four bits at a time from the nibble tables (XOR is exact and
 * commutes: the same bits as a loop over the set bits).  Eight loads and no
 * branch: a loop over the set bits has a data-dependent trip count, which
 * stops PoCL's work-item loop from vectorising ("could not determine number
 * of loop iterations"), and a fixed 32-step loop of branch-free selects
 * becomes 32 bit tests that clang's SLP vectoriser packs into a vector
 * compare, which stops it as well (measured, docs/contributing.md). */
BT_INLINE uint bt_sobol_u32(uint index, uint dim)
{
    uint x = 0u;
    uint d = dim < BT_SOBOL_DIMS ? dim : 0u;
    BT_SOBOL_UNROLL
    for (uint j = 0u; j < 8u; ++j) x ^= bt_sobol_nibble[d][j][(index >> (4u * j)) & 15u];
    return x;
}

/* 32-bit integer finaliser (bijective): xorshift-multiply rounds with the
 * "lowbias32" constants found by C. Wellons' hash prospector. */
BT_INLINE uint bt_hash32(uint x)
{
    x ^= x >> 16;
    x *= 0x7FEB352Du;
    x ^= x >> 15;
    x *= 0x846CA68Bu;
    x ^= x >> 16;
    return x;
}

/* Seed of one scramble from (key0, key1, cell, batch, dim): a chain of
 * hashes, each word entering after the previous ones were mixed. */
BT_INLINE uint bt_scramble_seed(uint key0, uint key1, uint cell, uint batch, uint dim)
{
    uint h = bt_hash32(key0 ^ 0x5BD1E995u);
    h = bt_hash32(h ^ key1);
    h = bt_hash32(h ^ cell);
    h = bt_hash32(h ^ batch);
    h = bt_hash32(h ^ (dim * 0x9E3779B9u));
    return h;
}

/* Nested uniform scramble of the top `digits` digits of x (1 <= digits <= 32):
 * digit k (k = 0 most significant) is flipped by the top bit of
 * bt_hash32(node_k * 0x9E3779B9 ^ seed), node_k = (1 << k) | digits 0..k-1.
 * Two forms of it, with the same bits (tests/test_sampler.cpp compares both
 * with a plain reference over random inputs):
 *
 * bt_owen_scramble_loop: the digits' hashes are independent iterations of a
 * loop, which clang vectorises inside the work item (8 hashes per
 * instruction).  The fastest form for a work item that loops over the
 * samples of a batch (the usual kernel) and for the host.
 *
 * bt_owen_scramble_chain: for one sample per work item (the sample-parallel
 * program), where PoCL's loop over the work items must vectorise instead, and
 * no vector value may appear inside a work item.  The loop is unrolled on the
 * device (a loop left in the kernel body is an inner loop of the work-item
 * loop, which is then not vectorised), and each flip bit is shifted into one
 * word that every step reads back: a chain, so clang's SLP vectoriser finds
 * no reduction and no pair of independent steps to pack into a small vector
 * (such a pack stops the work-item loop: "instruction return type cannot be
 * vectorized", docs/contributing.md). */
BT_INLINE uint bt_owen_scramble_loop(uint x, uint seed, uint digits)
{
    uint flips = 0u;
    for (uint k = 0u; k < digits; ++k) {
        uint prefix = k == 0u ? 0u : x >> (32u - k); /* digits 0..k-1 */
        uint node = (1u << k) | prefix;
        uint h = bt_hash32((node * 0x9E3779B9u) ^ seed);
        flips |= (h >> 31) << (31u - k);
    }
    return x ^ flips;
}

BT_INLINE uint bt_owen_scramble_chain(uint x, uint seed, uint digits)
{
    uint flips = 0u; /* after step k: the flips of digits 0..k, digit 0 highest */
    BT_SOBOL_UNROLL
    for (uint k = 0u; k < digits; ++k) {
        uint prefix = k == 0u ? 0u : x >> (32u - k); /* digits 0..k-1 */
        uint node = (1u << k) | prefix;
        uint h = bt_hash32((node * 0x9E3779B9u) ^ seed);
        flips = (flips << 1) | (h >> 31);
    }
    return x ^ (flips << (32u - digits));
}

/* The scramble of the top BT_SOBOL_SCRAMBLE_BITS digits (the rest never reach
 * the returned REAL).  The engine defines BT_SAMPLE_PARALLEL_PROGRAM at the
 * top of the sample-parallel program's source (host/engine/kernel_sources.cpp). */
BT_INLINE uint bt_owen_scramble(uint x, uint seed)
{
#if defined(BT_SAMPLE_PARALLEL_PROGRAM)
    return bt_owen_scramble_chain(x, seed, BT_SOBOL_SCRAMBLE_BITS);
#else
    return bt_owen_scramble_loop(x, seed, BT_SOBOL_SCRAMBLE_BITS);
#endif
}

#endif /* BRDFTAB_SOBOL_H */
