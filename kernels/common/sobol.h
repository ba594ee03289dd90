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
 * The table below is that expansion; tests/test_sampler.cpp re-derives it
 * from the (s, a, m) rows above and compares.
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

BT_TABLE uint bt_sobol_v[BT_SOBOL_DIMS][32] = {
    {0x80000000u, 0x40000000u, 0x20000000u, 0x10000000u, 0x08000000u, 0x04000000u,
     0x02000000u, 0x01000000u, 0x00800000u, 0x00400000u, 0x00200000u, 0x00100000u,
     0x00080000u, 0x00040000u, 0x00020000u, 0x00010000u, 0x00008000u, 0x00004000u,
     0x00002000u, 0x00001000u, 0x00000800u, 0x00000400u, 0x00000200u, 0x00000100u,
     0x00000080u, 0x00000040u, 0x00000020u, 0x00000010u, 0x00000008u, 0x00000004u,
     0x00000002u, 0x00000001u},
    {0x80000000u, 0xC0000000u, 0xA0000000u, 0xF0000000u, 0x88000000u, 0xCC000000u,
     0xAA000000u, 0xFF000000u, 0x80800000u, 0xC0C00000u, 0xA0A00000u, 0xF0F00000u,
     0x88880000u, 0xCCCC0000u, 0xAAAA0000u, 0xFFFF0000u, 0x80008000u, 0xC000C000u,
     0xA000A000u, 0xF000F000u, 0x88008800u, 0xCC00CC00u, 0xAA00AA00u, 0xFF00FF00u,
     0x80808080u, 0xC0C0C0C0u, 0xA0A0A0A0u, 0xF0F0F0F0u, 0x88888888u, 0xCCCCCCCCu,
     0xAAAAAAAAu, 0xFFFFFFFFu},
    {0x80000000u, 0xC0000000u, 0x60000000u, 0x90000000u, 0xE8000000u, 0x5C000000u,
     0x8E000000u, 0xC5000000u, 0x68800000u, 0x9CC00000u, 0xEE600000u, 0x55900000u,
     0x80680000u, 0xC09C0000u, 0x60EE0000u, 0x90550000u, 0xE8808000u, 0x5CC0C000u,
     0x8E606000u, 0xC5909000u, 0x6868E800u, 0x9C9C5C00u, 0xEEEE8E00u, 0x5555C500u,
     0x8000E880u, 0xC0005CC0u, 0x60008E60u, 0x9000C590u, 0xE8006868u, 0x5C009C9Cu,
     0x8E00EEEEu, 0xC5005555u},
    {0x80000000u, 0xC0000000u, 0x20000000u, 0x50000000u, 0xF8000000u, 0x74000000u,
     0xA2000000u, 0x93000000u, 0xD8800000u, 0x25400000u, 0x59E00000u, 0xE6D00000u,
     0x78080000u, 0xB40C0000u, 0x82020000u, 0xC3050000u, 0x208F8000u, 0x51474000u,
     0xFBEA2000u, 0x75D93000u, 0xA0858800u, 0x914E5400u, 0xDBE79E00u, 0x25DB6D00u,
     0x58800080u, 0xE54000C0u, 0x79E00020u, 0xB6D00050u, 0x800800F8u, 0xC00C0074u,
     0x200200A2u, 0x50050093u},
    {0x80000000u, 0x40000000u, 0x20000000u, 0xB0000000u, 0xF8000000u, 0xDC000000u,
     0x7A000000u, 0x9D000000u, 0x5A800000u, 0x2FC00000u, 0xA1600000u, 0xF0B00000u,
     0xDA880000u, 0x6FC40000u, 0x81620000u, 0x40BB0000u, 0x22878000u, 0xB3C9C000u,
     0xFB65A000u, 0xDDB2D000u, 0x78022800u, 0x9C0B3C00u, 0x5A0FB600u, 0x2D0DDB00u,
     0xA2878080u, 0xF3C9C040u, 0xDB65A020u, 0x6DB2D0B0u, 0x800228F8u, 0x400B3CDCu,
     0x200FB67Au, 0xB00DDB9Du},
    {0x80000000u, 0x40000000u, 0x60000000u, 0x30000000u, 0xC8000000u, 0x24000000u,
     0x56000000u, 0xFB000000u, 0xE0800000u, 0x70400000u, 0xA8600000u, 0x14300000u,
     0x9EC80000u, 0xDF240000u, 0xB6D60000u, 0x8BBB0000u, 0x48008000u, 0x64004000u,
     0x36006000u, 0xCB003000u, 0x2880C800u, 0x54402400u, 0xFE605600u, 0xEF30FB00u,
     0x7E48E080u, 0xAF647040u, 0x1EB6A860u, 0x9F8B1430u, 0xD6C81EC8u, 0xBB249F24u,
     0x80D6D6D6u, 0x40BBBBBBu},
    {0x80000000u, 0xC0000000u, 0xA0000000u, 0xD0000000u, 0x58000000u, 0x94000000u,
     0x3E000000u, 0xE3000000u, 0xBE800000u, 0x23C00000u, 0x1E200000u, 0xF3100000u,
     0x46780000u, 0x67840000u, 0x78460000u, 0x84670000u, 0xC6788000u, 0xA784C000u,
     0xD846A000u, 0x5467D000u, 0x9E78D800u, 0x33845400u, 0xE6469E00u, 0xB7673300u,
     0x20F86680u, 0x104477C0u, 0xF8668020u, 0x4477C010u, 0x668020F8u, 0x77C01044u,
     0x8020F866u, 0xC0104477u},
    {0x80000000u, 0x40000000u, 0xA0000000u, 0x50000000u, 0x88000000u, 0x24000000u,
     0x12000000u, 0x2D000000u, 0x76800000u, 0x9E400000u, 0x08200000u, 0x64100000u,
     0xB2280000u, 0x7D140000u, 0xFEA20000u, 0xBA490000u, 0x1A248000u, 0x491B4000u,
     0xC4B5A000u, 0xE3739000u, 0xF6800800u, 0xDE400400u, 0xA8200A00u, 0x34100500u,
     0x3A280880u, 0x59140240u, 0xECA20120u, 0x974902D0u, 0x6CA48768u, 0xD75B49E4u,
     0xCC95A082u, 0x87639641u},
};

/* Unscrambled Sobol' coordinate `dim` of point `index`, as 32 bits
 * (the point is this value / 2^32).  Direct (non-Gray-code) order, so point
 * `index` is a pure function of index. */
BT_INLINE uint bt_sobol_u32(uint index, uint dim)
{
    uint x = 0u;
    uint d = dim < BT_SOBOL_DIMS ? dim : 0u;
    for (uint k = 0u; index != 0u; ++k, index >>= 1)
        if (index & 1u) x ^= bt_sobol_v[d][k];
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

/* Nested uniform scramble of the top BT_SOBOL_SCRAMBLE_BITS digits of x. */
BT_INLINE uint bt_owen_scramble(uint x, uint seed)
{
    uint flips = 0u;
    for (uint k = 0u; k < BT_SOBOL_SCRAMBLE_BITS; ++k) {
        uint prefix = k == 0u ? 0u : x >> (32u - k); /* digits 0..k-1 */
        uint node = (1u << k) | prefix;
        uint h = bt_hash32((node * 0x9E3779B9u) ^ seed);
        flips |= (h >> 31) << (31u - k);
    }
    return x ^ flips;
}

#endif /* BRDFTAB_SOBOL_H */
