// RANSAC scoring (DESIGN section 5): each work-item scores 16 hypotheses (one per float16 lane,
// as the dissertation's VideoCore kernel did) against every match, the matches broadcast.
// Arithmetic mirrors gpu/score_simd.cpp operation for operation: no contraction, explicit fma()
// only where the CPU kernel uses FMA (OVO_FMA, set by the host to match it), so the counts agree
// bit for bit. E is stored as 9 planes of `hyp_stride` floats (plane j = entry j of the
// row-major E), bearings as x, y, z planes of n floats.
#pragma OPENCL FP_CONTRACT OFF

#if OVO_FMA
#define MADD(a, b, c) fma((a), (b), (c))
#else
#define MADD(a, b, c) ((a) * (b) + (c))
#endif

__kernel void ransac_score16(__global const float* E, const int hyp_stride,
                             __global const float* bp, __global const float* bc, const int n,
                             const float k, __global int* counts) {
  const int h0 = (int)get_global_id(0) * 16;
  const float16 e0 = vload16(0, E + 0 * hyp_stride + h0);
  const float16 e1 = vload16(0, E + 1 * hyp_stride + h0);
  const float16 e2 = vload16(0, E + 2 * hyp_stride + h0);
  const float16 e3 = vload16(0, E + 3 * hyp_stride + h0);
  const float16 e4 = vload16(0, E + 4 * hyp_stride + h0);
  const float16 e5 = vload16(0, E + 5 * hyp_stride + h0);
  const float16 e6 = vload16(0, E + 6 * hyp_stride + h0);
  const float16 e7 = vload16(0, E + 7 * hyp_stride + h0);
  const float16 e8 = vload16(0, E + 8 * hyp_stride + h0);
  const float16 kv = (float16)(k);
  int16 count = (int16)(0);
  for (int i = 0; i < n; ++i) {
    const float16 px = (float16)(bp[i]);
    const float16 py = (float16)(bp[n + i]);
    const float16 pz = (float16)(bp[2 * n + i]);
    const float16 cx = (float16)(bc[i]);
    const float16 cy = (float16)(bc[n + i]);
    const float16 cz = (float16)(bc[2 * n + i]);
    const float16 a0 = MADD(e2, pz, MADD(e1, py, e0 * px));
    const float16 a1 = MADD(e5, pz, MADD(e4, py, e3 * px));
    const float16 a2 = MADD(e8, pz, MADD(e7, py, e6 * px));
    const float16 c0 = MADD(e6, cz, MADD(e3, cy, e0 * cx));
    const float16 c1 = MADD(e7, cz, MADD(e4, cy, e1 * cx));
    const float16 c2 = MADD(e8, cz, MADD(e5, cy, e2 * cx));
    const float16 num = MADD(cz, a2, MADD(cy, a1, cx * a0));
    const float16 s = MADD(c2, c2, MADD(c1, c1, MADD(c0, c0, MADD(a2, a2, MADD(a1, a1, a0 * a0)))));
    count -= isless(num * num, kv * s);  // -1 per true lane
  }
  vstore16(count, 0, counts + h0);
}
