// RANSAC hypothesis generation on the device (DESIGN sections 4, 5): each work-item draws and
// solves 8 consecutive hypotheses, one per double8 lane, operation for operation as
// gpu/hypotheses_simd.cpp does (splitmix64 samples, Householder QR null vector, cyclic Jacobi
// projection). Only correctly rounded +, -, *, /, sqrt, no contraction, so every E has the CPU's
// bits. Output: E as 9 float planes of `hyp_stride` (plane j = entry j of the row-major E), the
// layout ransac_score16 reads; bearings as x, y, z planes of n doubles.
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

#define KSWEEPS 5

ulong splitmix64(ulong* state) {
  ulong z = (*state += 0x9E3779B97F4A7C15UL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9UL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBUL;
  return z ^ (z >> 31);
}

// gpu::sampleIndices: Lemire's multiply-shift (x n) >> 64 is mul_hi(x, n).
void sampleIndices(ulong seed, ulong k, int n, int idx[8]) {
  ulong key = seed;
  ulong state = splitmix64(&key) ^ ((k + 1) * 0xD1B54A32D192ED03UL);
  for (int j = 0; j < 8; ++j) {
    for (;;) {
      const int c = (int)mul_hi(splitmix64(&state), (ulong)n);
      bool fresh = true;
      for (int i = 0; i < j; ++i) fresh = fresh && idx[i] != c;
      if (fresh) {
        idx[j] = c;
        break;
      }
    }
  }
}

// One cyclic Jacobi rotation zeroing S(p, q) on every lane (gpu/hypotheses_simd.cpp).
void jacobiRotate(double8 S[3][3], double8 V[3][3], int p, int q) {
  const double8 apq = S[p][q];
  const long8 nonzero = isnotequal(apq, 0.0);
  const double8 tau = (S[q][q] - S[p][p]) / select((double8)(1.0), 2.0 * apq, nonzero);
  const double8 t_raw = copysign((double8)(1.0), tau) / (fabs(tau) + sqrt(1.0 + tau * tau));
  const double8 t = select((double8)(0.0), t_raw, nonzero);
  const double8 c = 1.0 / sqrt(1.0 + t * t);
  const double8 s = t * c;
  for (int r = 0; r < 3; ++r) {
    const double8 sp = S[r][p], sq = S[r][q];
    S[r][p] = c * sp - s * sq;
    S[r][q] = s * sp + c * sq;
    const double8 vp = V[r][p], vq = V[r][q];
    V[r][p] = c * vp - s * vq;
    V[r][q] = s * vp + c * vq;
  }
  for (int r = 0; r < 3; ++r) {
    const double8 sp = S[p][r], sq = S[q][r];
    S[p][r] = c * sp - s * sq;
    S[q][r] = s * sp + c * sq;
  }
}

__kernel void ransac_hypotheses8(__global const double* bp, __global const double* bc,
                                 const int n, const ulong seed, const int h_begin,
                                 __global float* E_planes, const int hyp_stride) {
  const int local0 = (int)get_global_id(0) * 8;  // hypotheses h_begin + local0 .. + 7
  double8 A[8][9];
  {
    double pv[8][3][8], cv[8][3][8];  // [match][axis][lane]
    for (int l = 0; l < 8; ++l) {
      int idx[8];
      sampleIndices(seed, (ulong)(h_begin + local0 + l), n, idx);
      for (int j = 0; j < 8; ++j)
        for (int r = 0; r < 3; ++r) {
          pv[j][r][l] = bp[r * n + idx[j]];
          cv[j][r][l] = bc[r * n + idx[j]];
        }
    }
    for (int i = 0; i < 8; ++i)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) A[i][3 * r + c] = vload8(0, cv[i][r]) * vload8(0, pv[i][c]);
  }

  // Householder QR of A^T (9x8): reflector k acts on entries k..8 and is stored in row k.
  double8 beta[8];
  for (int k = 0; k < 8; ++k) {
    double8 norm2 = 0.0;
    for (int j = k; j < 9; ++j) norm2 += A[k][j] * A[k][j];
    const double8 norm = sqrt(norm2);
    const double8 x0 = A[k][k];
    const double8 vnorm2 = 2.0 * norm * (norm + fabs(x0));
    A[k][k] = x0 + copysign(norm, x0);
    beta[k] = select((double8)(0.0), 2.0 / vnorm2, isgreater(vnorm2, 0.0));
    for (int i = k + 1; i < 8; ++i) {
      double8 d = 0.0;
      for (int j = k; j < 9; ++j) d += A[k][j] * A[i][j];
      d *= beta[k];
      for (int j = k; j < 9; ++j) A[i][j] -= d * A[k][j];
    }
  }
  double8 z[9];
  for (int j = 0; j < 9; ++j) z[j] = j == 8 ? 1.0 : 0.0;
  for (int k = 7; k >= 0; --k) {
    double8 d = 0.0;
    for (int j = k; j < 9; ++j) d += A[k][j] * z[j];
    d *= beta[k];
    for (int j = k; j < 9; ++j) z[j] -= d * A[k][j];
  }

  double8 S[3][3], V[3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      S[a][b] = z[a] * z[b] + z[3 + a] * z[3 + b] + z[6 + a] * z[6 + b];
      V[a][b] = a == b ? 1.0 : 0.0;
    }
  for (int sweep = 0; sweep < KSWEEPS; ++sweep) {
    jacobiRotate(S, V, 0, 1);
    jacobiRotate(S, V, 0, 2);
    jacobiRotate(S, V, 1, 2);
  }
  const double8 d0 = S[0][0], d1 = S[1][1], d2 = S[2][2];
  const long8 first = islessequal(d0, d1) & islessequal(d0, d2);  // smallest == 0
  const long8 last = ~first & ~islessequal(d1, d2);                 // smallest == 2
  double8 v1[3], v2[3], u1[3], u2[3];
  for (int r = 0; r < 3; ++r) {
    v1[r] = select(V[r][0], V[r][1], first);
    v2[r] = select(V[r][2], V[r][1], last);
  }
  for (int r = 0; r < 3; ++r) {
    u1[r] = z[3 * r] * v1[0] + z[3 * r + 1] * v1[1] + z[3 * r + 2] * v1[2];
    u2[r] = z[3 * r] * v2[0] + z[3 * r + 1] * v2[1] + z[3 * r + 2] * v2[2];
  }
  const double8 n1 = sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2]);
  const double8 n2 = sqrt(u2[0] * u2[0] + u2[1] * u2[1] + u2[2] * u2[2]);
  const double8 n_max = select(n1, n2, isless(n1, n2));  // std::max(n1, n2)
  const double8 n_min = select(n1, n2, isless(n2, n1));  // std::min(n1, n2)
  long8 ok = isgreater(n_max, 0.0) & isgreater(n_min, 1e-9 * n_max) & isless(n_max, 1e300);
  const double8 inv1 = select((double8)(0.0), 1.0 / n1, ok);
  const double8 inv2 = select((double8)(0.0), 1.0 / n2, ok);
  double8 e[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      e[3 * r + c] = u1[r] * inv1 * v1[c] + u2[r] * inv2 * v2[c];
      ok = ok & isfinite(e[3 * r + c]);
    }
  for (int j = 0; j < 9; ++j)
    vstore8(convert_float8(select((double8)(0.0), e[j], ok)), 0,
            E_planes + j * hyp_stride + local0);
}
