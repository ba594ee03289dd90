/*
 * philox.h — Philox-4x32-10 counter-based generator.
 *
 * J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw, "Parallel random
 * numbers: as easy as 1, 2, 3", SC 2011.  Written from the published
 * algorithm:
 *   round:  (hi0, lo0) = M0 * c0,  (hi1, lo1) = M1 * c2      (32x32 -> 64 bit)
 *           c' = (hi1 ^ c1 ^ k0,  lo1,  hi0 ^ c3 ^ k1,  lo0)
 *   key schedule between rounds: k0 += W0, k1 += W1 (Weyl sequence)
 *   M0 = 0xD2511F53, M1 = 0xCD9E8D57, W0 = 0x9E3779B9, W1 = 0xBB67AE85,
 *   10 rounds.
 * The 64-bit product uses mul_hi() on the device and a 64-bit multiply on
 * the host; both give identical bits.  Checked against Random123's
 * known-answer vectors in tests/test_sampler.cpp.
 */
#ifndef BRDFTAB_PHILOX_H
#define BRDFTAB_PHILOX_H

#include "compat.h"

#define BT_PHILOX_M0 0xD2511F53u
#define BT_PHILOX_M1 0xCD9E8D57u
#define BT_PHILOX_W0 0x9E3779B9u
#define BT_PHILOX_W1 0xBB67AE85u

/* High word of the 64-bit product, on the device too: PoCL's CPU build of
 * OpenCL's mul_hi(uint, uint) is a software routine of 16-bit partial
 * products (its machine code multiplies by 0xd251 and 0x1f53, the halves of
 * BT_PHILOX_M0), measured at 53 % of a lambert-sphere brdf_mc kernel's time
 * against 25 % with the 64-bit product (docs/contributing.md).  Both are exact,
 * so the words are the same; GPU compilers turn this form into their
 * mul-high instruction. */
BT_INLINE uint bt_mulhi32(uint a, uint b)
{
    return (uint)(((ulong)a * (ulong)b) >> 32);
}

/* One Philox-4x32-10 block: counter c[0..3], key (k0, k1) -> out[0..3]. */
BT_INLINE void bt_philox4x32_10(uint c0, uint c1, uint c2, uint c3, uint k0, uint k1,
                                uint* out)
{
    /* Unrolled on the device: left as a loop, the ten rounds are an inner
     * loop of PoCL's work-item loop, which then is not innermost and stays
     * scalar (the sample-parallel kernel, kernels/common/estimator.h,
     * vectorises once they are unrolled: docs/contributing.md).  Same
     * operations in the same order. */
#if BT_DEVICE
#pragma unroll
#endif
    for (int r = 0; r < 10; ++r) {
        if (r > 0) {
            k0 += BT_PHILOX_W0;
            k1 += BT_PHILOX_W1;
        }
        uint hi0 = bt_mulhi32(BT_PHILOX_M0, c0);
        uint lo0 = BT_PHILOX_M0 * c0;
        uint hi1 = bt_mulhi32(BT_PHILOX_M1, c2);
        uint lo1 = BT_PHILOX_M1 * c2;
        c0 = hi1 ^ c1 ^ k0;
        c1 = lo1;
        c2 = hi0 ^ c3 ^ k1;
        c3 = lo0;
    }
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
    out[3] = c3;
}

/* Word `word` (0..3) of the block: the form the sampler uses. */
BT_INLINE uint bt_philox4x32_10_word(uint c0, uint c1, uint c2, uint c3, uint k0, uint k1,
                                     uint word)
{
    uint out[4];
    bt_philox4x32_10(c0, c1, c2, c3, k0, k1, out);
    return out[word & 3u];
}

#endif /* BRDFTAB_PHILOX_H */
