// The batched fitness kernel, compiled once per instruction-set path (kernel/batch_kernel.h);
// see kernel/batch_fitness.h for what it computes. Design notes:
//
//  - Vectors are GCC vector extensions of 8 doubles (one zmm register with AVX-512; a portable
//    build lowers them to narrower registers). A group advances N = 1..2 vectors together; every
//    operation is written once per lane and applied to the N vectors back to back, so N
//    independent dependency chains are interleaved in program order (3 vectors spill registers
//    and run slower on this kernel). No operation mixes lanes, and the file is compiled with
//    -ffp-contract=off with every fused multiply-add written out, so a lane's arithmetic does not
//    depend on its neighbours, on N or on the thread count: results are bit-identical for any
//    grouping.
//  - Each step is split in two passes over blocks of 16 IMU steps: phase A (data and parameters
//    only: compensation, sculling, coning, the body-rotation quaternion) into an L1-resident
//    buffer, phase B (the recurrence: velocity, position, attitude, Eq. 15).
//  - No libm call in the loop. sin/cos of each lane's latitude are exact every 32 steps (a
//    shared reference latitude with libm sin/cos every 64 steps, the lane's offset from it through
//    Taylor series to degree 9/10) and carried between by first-order updates in the step's
//    latitude change (~3e-8 rad); curvature radii likewise (one square root per 32 steps). The
//    other latitudes the reference evaluates (extrapolated mid-point, trapezoidal mid-points) are
//    first-order expansions about the old latitude (~1e-16 relative: an Earth or transport rate
//    off by that turns the attitude by < 1e-22 rad per step). The divisions 1/(R + h) are exact.
//  - Rotation-vector quaternions: series of cos(x/2) and sin(x/2)/x (degree 6 for the body
//    rotation, truncation < 2e-22 for |x| < 0.06 rad per step; degree 2 for the n-frame rotation).
//  - What matters at 1e-12: the attitude and velocity integrate ~1e5 tiny increments into values
//    whose ulp is far larger, so the rounding of those sums is biased by their arithmetic order.
//    The quaternion products follow Eigen's SSE code as GCC 12 compiles the reference for an FMA
//    target (which product of each pair is fused), the normalisation is q / RN(sqrt(|q|^2))
//    exactly (without the square root, see below), the velocity is summed (v + dv_sf) + dv_cor.
//    A different but "equally exact" order drifts ~1e-17 rad per step from the reference, 1e-9 of
//    the fitness after ten minutes. With it the kernel matched an FMA-compiled reference to
//    ~1e-12 relative. The reference is compiled for baseline x86-64, without FMA:
//    the baseline path (unfused, like it) matches it to ~5e-12, the FMA paths to ~3e-10 (ten
//    minutes of the paper flight; tests/batch_fitness_test.cc).
//  - The shared height average (see phase B) and the other approximations change the fitness by
//    less than 1e-11 relative; batch_fitness_test.cc checks 1e-9 on three scenarios.

#include "kernel/batch_kernel.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <immintrin.h>

#include "nav/mechanization.h"

// Every header above is read before the instruction set changes (batch_kernel.h: no inline
// function of a header carries a kernel path's instructions). The path this compilation builds
// (kernel/CMakeLists.txt): INSID_KERNEL_PATH_AVX512 / _AVX2 / _BASELINE under CPU dispatch, the
// program being baseline x86-64; none: the build's own instruction set (INSID_CPU_DISPATCH=OFF).
// GCC's C++ front end does not redefine __AVX512F__ etc. after `#pragma GCC target`, hence the
// INSID_K_* macros.
#if defined(INSID_KERNEL_PATH_AVX512)
#pragma GCC target("arch=x86-64-v4,prefer-vector-width=512")
#define INSID_KERNEL_NS kernel_avx512
#define INSID_KERNEL_NAME "avx512"
#define INSID_KERNEL_DESCRIPTION "avx512 (kernel for x86-64-v4: AVX-512; the rest x86-64)"
#define INSID_K_AVX512 1
#define INSID_K_AVX 1
#define INSID_K_FMA 1
#elif defined(INSID_KERNEL_PATH_AVX2)
#pragma GCC target("arch=x86-64-v3")
#define INSID_KERNEL_NS kernel_avx2
#define INSID_KERNEL_NAME "avx2"
#define INSID_KERNEL_DESCRIPTION "avx2 (kernel for x86-64-v3: AVX2 + FMA; the rest x86-64)"
#define INSID_K_AVX 1
#define INSID_K_FMA 1
#elif defined(INSID_KERNEL_PATH_BASELINE)
#define INSID_KERNEL_NS kernel_baseline
#define INSID_KERNEL_NAME "baseline"
#define INSID_KERNEL_DESCRIPTION "baseline (x86-64: SSE2)"
#else
#define INSID_KERNEL_NS kernel_native
#define INSID_KERNEL_NAME "native"
#ifndef INSID_CPU_PATH
#define INSID_CPU_PATH "unknown"
#endif
#define INSID_KERNEL_DESCRIPTION INSID_CPU_PATH
#if defined(__AVX512F__)
#define INSID_K_AVX512 1
#endif
#if defined(__AVX__)
#define INSID_K_AVX 1
#endif
#if defined(__FMA__)
#define INSID_K_FMA 1
#endif
#endif

namespace insid::INSID_KERNEL_NS {

using namespace insid::batch_kernel;

namespace {

#define INSID_AI inline __attribute__((always_inline))

#if defined(INSID_K_AVX512)
using v8 = double __attribute__((vector_size(64)));
using m8 = decltype(v8{} < v8{});

INSID_AI v8 splat(double x) { return v8{x, x, x, x, x, x, x, x}; }
#else
// The AVX2 and baseline paths of the dispatching build (CMakeLists.txt, INSID_CPU_DISPATCH): a
// 64-byte GCC vector has no register there and lived on the stack between its 256-bit halves (the
// AVX2 build ran 11x slower than AVX-512 with its FMAs fused). An 8-lane vector is instead a
// struct of kPieces native vectors (2 x 256-bit with AVX, 4 x 128-bit with SSE2), each its own
// register; every operation is applied piece by piece, so each lane's arithmetic is unchanged.
#if defined(INSID_K_AVX)
using vpiece = double __attribute__((vector_size(32)));
#else
using vpiece = double __attribute__((vector_size(16)));
#endif
using mpiece = decltype(vpiece{} < vpiece{});
constexpr int kPieceLanes = static_cast<int>(sizeof(vpiece) / sizeof(double));
constexpr int kPieces = W / kPieceLanes;
template <class Piece, class Lane>
struct Pieces {
  Piece h[kPieces];
  INSID_AI Lane& operator[](int j) { return reinterpret_cast<Lane*>(h)[j]; }
  INSID_AI Lane operator[](int j) const { return h[j / kPieceLanes][j % kPieceLanes]; }
};
using v8 = Pieces<vpiece, double>;
using m8 = Pieces<mpiece, std::int64_t>;

#define INSID_PIECEWISE(op)                                      \
  INSID_AI v8 operator op(const v8& a, const v8& b) {            \
    v8 r;                                                        \
    for (int k = 0; k < kPieces; ++k) r.h[k] = a.h[k] op b.h[k]; \
    return r;                                                    \
  }
INSID_PIECEWISE(+)
INSID_PIECEWISE(-)
INSID_PIECEWISE(*)
INSID_PIECEWISE(/)
#undef INSID_PIECEWISE
INSID_AI v8 operator-(const v8& a) {
  v8 r;
  for (int k = 0; k < kPieces; ++k) r.h[k] = -a.h[k];
  return r;
}
INSID_AI v8 splat(double x) {
  v8 r;
#if defined(INSID_K_AVX)
  for (int k = 0; k < kPieces; ++k) r.h[k] = _mm256_set1_pd(x);
#else
  for (int k = 0; k < kPieces; ++k) r.h[k] = _mm_set1_pd(x);
#endif
  return r;
}
#define INSID_PIECEWISE_COMPARE(op)                               \
  INSID_AI m8 operator op(const v8& a, double b) {                \
    m8 r;                                                         \
    const v8 bb = splat(b);                                       \
    for (int k = 0; k < kPieces; ++k) r.h[k] = a.h[k] op bb.h[k]; \
    return r;                                                     \
  }
INSID_PIECEWISE_COMPARE(<)
INSID_PIECEWISE_COMPARE(>)
#undef INSID_PIECEWISE_COMPARE
INSID_AI v8 sqrt8(const v8& a) {
  v8 r;
#if defined(INSID_K_AVX)
  for (int k = 0; k < kPieces; ++k) r.h[k] = _mm256_sqrt_pd(a.h[k]);
#else
  for (int k = 0; k < kPieces; ++k) r.h[k] = _mm_sqrt_pd(a.h[k]);
#endif
  return r;
}
#endif

// N vectors of 8 lanes, operated on back to back.
template <int N>
struct P {
  v8 c[N];
};
template <int N>
struct M {
  m8 c[N];
};

#define INSID_BINOP(op)                                     \
  template <int N>                                          \
  INSID_AI P<N> operator op(const P<N>& a, const P<N>& b) { \
    P<N> r;                                                 \
    for (int i = 0; i < N; ++i) r.c[i] = a.c[i] op b.c[i];  \
    return r;                                               \
  }                                                         \
  template <int N>                                          \
  INSID_AI P<N> operator op(const P<N>& a, double b) {      \
    P<N> r;                                                 \
    const v8 bb = splat(b);                                 \
    for (int i = 0; i < N; ++i) r.c[i] = a.c[i] op bb;      \
    return r;                                               \
  }                                                         \
  template <int N>                                          \
  INSID_AI P<N> operator op(double a, const P<N>& b) {      \
    P<N> r;                                                 \
    const v8 aa = splat(a);                                 \
    for (int i = 0; i < N; ++i) r.c[i] = aa op b.c[i];      \
    return r;                                               \
  }
INSID_BINOP(+)
INSID_BINOP(-)
INSID_BINOP(*)
INSID_BINOP(/)
#undef INSID_BINOP

template <int N>
INSID_AI P<N> operator-(const P<N>& a) {
  P<N> r;
  for (int i = 0; i < N; ++i) r.c[i] = -a.c[i];
  return r;
}

// Fused multiply-add, written out: the kernel is compiled with -ffp-contract=off so that the
// compiler never decides on its own where to fuse (its choices could differ between the 1-, 2-
// and 3-vector instantiations and break bit-identity across groupings).
template <class T>
struct Chains {
  static constexpr int value = 0;
};
template <int N>
struct Chains<P<N>> {
  static constexpr int value = N;
};
template <int N>
INSID_AI v8 part(const P<N>& a, int i) {
  return a.c[i];
}
INSID_AI v8 part(double a, int) { return splat(a); }
// The three CPU paths of the dispatching build (CMakeLists.txt, INSID_CPU_DISPATCH) each lower
// it to their widest FMA; one rounding per lane on both FMA paths, so they agree to the bit here.
INSID_AI v8 fma8(v8 a, v8 b, v8 c) {
#if defined(INSID_K_AVX512)
  v8 r;  // one 512-bit FMA
  for (int j = 0; j < W; ++j) r[j] = __builtin_fma(a[j], b[j], c[j]);
  return r;
#elif defined(INSID_K_FMA)
  // AVX2 + FMA: GCC 12 turns the per-lane loop above into one scalar FMA per lane there (the
  // AVX2 build ran 13x slower); one 256-bit FMA per piece.
  v8 r;
  for (int k = 0; k < kPieces; ++k) r.h[k] = _mm256_fmadd_pd(a.h[k], b.h[k], c.h[k]);
  return r;
#else
  return a * b + c;  // no FMA instruction: unfused, still the same for every lane
#endif
}
/// a * b + c with one rounding (where the CPU has FMA).
template <class A, class B, class C,
          int N = std::max({Chains<A>::value, Chains<B>::value, Chains<C>::value})>
INSID_AI P<N> fma(const A& a, const B& b, const C& c) {
  P<N> r;
  for (int i = 0; i < N; ++i) r.c[i] = fma8(part(a, i), part(b, i), part(c, i));
  return r;
}

template <int N>
INSID_AI P<N> bcast(double x) {
  P<N> r;
  for (int i = 0; i < N; ++i) r.c[i] = splat(x);
  return r;
}

template <int N>
INSID_AI P<N> vsqrt(const P<N>& a) {
  P<N> r;
#if defined(INSID_K_AVX512)
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < W; ++j) r.c[i][j] = __builtin_sqrt(a.c[i][j]);
#else
  for (int i = 0; i < N; ++i) r.c[i] = sqrt8(a.c[i]);
#endif
  return r;
}

template <int N>
INSID_AI P<N> blend(const M<N>& m, const P<N>& a, const P<N>& b) {
  P<N> r;
#if defined(INSID_K_AVX512)
  for (int i = 0; i < N; ++i) r.c[i] = m.c[i] ? a.c[i] : b.c[i];
#else
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < kPieces; ++k) r.c[i].h[k] = m.c[i].h[k] ? a.c[i].h[k] : b.c[i].h[k];
#endif
  return r;
}

template <int N>
INSID_AI double lane(const P<N>& a, int l) {
  return a.c[l / W][l % W];
}

// Cross product helper on packs.
template <int N>
struct V3 {
  P<N> x, y, z;
};
template <int N>
INSID_AI V3<N> cross(const P<N>& ax, const P<N>& ay, const P<N>& az, const P<N>& bx, const P<N>& by,
                     const P<N>& bz) {
  return {ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx};
}

// One value per lane from each lane's LaneInit.
template <int N, class Get>
INSID_AI P<N> gather_lanes(LaneInit* const* lanes, Get get) {
  P<N> r;
  for (int l = 0; l < N * W; ++l) r.c[l / W][l % W] = get(*lanes[l]);
  return r;
}

// Phase A's result for one step, kept in a block buffer for phase B.
template <int N>
struct Pre {
  P<N> fx, fy, fz;        // velocity increment in b, sculling-corrected [m/s]
  P<N> pw, px, py, pz;    // body-rotation quaternion of the step (coning-corrected)
  P<N> dthx, dthy, dthz;  // compensated angle increment in b [rad]
};

// The lanes of one group: their error model, navigation state and Earth terms, and the phases
// of a step as member functions, always inlined into run_group (one object per group, on the
// stack; the arithmetic and its order are those of the single function it was).
template <int N, bool kGeneral, bool kLever>
struct Group {
  using PN = P<N>;

  // Parameters, one lane per candidate (LaneInit's fields): bg* gyro bias b [rad/s], dg* its
  // drift [rad/s^2], ba* accelerometer bias b [m/s^2], da* its drift [m/s^3], Gi / Ai the inverse
  // distortion matrices [1], l* lever arm b [m].
  PN bgx, bgy, bgz, dgx, dgy, dgz, bax, bay, baz, dax, day, daz;
  // mg* / mf*: the gyro [rad/s] and accelerometer [m/s^2] offsets while the motors run.
  PN mgx, mgy, mgz, mfx, mfy, mfz;
  PN Gi[9], Ai[9];
  PN lx{}, ly{}, lz{};
  // State: lat [rad]; vE, vN the INS velocity in n = ENU [m/s] (vEp, vNp at the step before);
  // q* the attitude quaternion b -> n; dthp* [rad], dvp* [m/s], omp* [rad/s] the compensated
  // increments and mean rate of the step before (two-sample corrections, lever arm); vaEp, vaNp
  // the antenna velocity at the step before [m/s] and acc the running Eq. 15 sum are the
  // driver's (run_group's epoch handling holds them by reference, so they live on its stack,
  // not in this object, which then stays in registers).
  PN lat, em{}, vE, vN, vEp, vNp, qw, qx, qy, qz;
  PN dthpx, dthpy, dthpz, dvpx, dvpy, dvpz, ompx{}, ompy{}, ompz{};
  // Earth terms of each lane at its current latitude: exact (series about the reference, one
  // square root and division) every 32 steps, carried between by first-order updates in the
  // step's latitude change (~3e-8 rad; the dropped second-order terms sum to < 2e-14 relative
  // over 32 steps). kk = (dRN/dlat)/RN = (dRM/dlat)/(3 RM) and the derivatives are held.
  PN es{}, ec{}, eRN{}, eRM{}, edRN{}, edRM{}, ekk{}, ekk3{};

  // Each lane from its LaneInit.
  INSID_AI explicit Group(LaneInit* const* lanes) {
    auto gather = [lanes](auto get) { return gather_lanes<N>(lanes, get); };
    bgx = gather([](const LaneInit& li) { return li.gyro_bias_b_rad_s[0]; });
    bgy = gather([](const LaneInit& li) { return li.gyro_bias_b_rad_s[1]; });
    bgz = gather([](const LaneInit& li) { return li.gyro_bias_b_rad_s[2]; });
    dgx = gather([](const LaneInit& li) { return li.gyro_bias_drift_b_rad_s2[0]; });
    dgy = gather([](const LaneInit& li) { return li.gyro_bias_drift_b_rad_s2[1]; });
    dgz = gather([](const LaneInit& li) { return li.gyro_bias_drift_b_rad_s2[2]; });
    bax = gather([](const LaneInit& li) { return li.accel_bias_b_mps2[0]; });
    bay = gather([](const LaneInit& li) { return li.accel_bias_b_mps2[1]; });
    baz = gather([](const LaneInit& li) { return li.accel_bias_b_mps2[2]; });
    dax = gather([](const LaneInit& li) { return li.accel_bias_drift_b_mps3[0]; });
    day = gather([](const LaneInit& li) { return li.accel_bias_drift_b_mps3[1]; });
    daz = gather([](const LaneInit& li) { return li.accel_bias_drift_b_mps3[2]; });
    mgx = gather([](const LaneInit& li) { return li.gyro_motor_offset_b_rad_s[0]; });
    mgy = gather([](const LaneInit& li) { return li.gyro_motor_offset_b_rad_s[1]; });
    mgz = gather([](const LaneInit& li) { return li.gyro_motor_offset_b_rad_s[2]; });
    mfx = gather([](const LaneInit& li) { return li.accel_motor_offset_b_mps2[0]; });
    mfy = gather([](const LaneInit& li) { return li.accel_motor_offset_b_mps2[1]; });
    mfz = gather([](const LaneInit& li) { return li.accel_motor_offset_b_mps2[2]; });
    if constexpr (kGeneral) {
      // Identity rows and columns give the same bits as the fast path (1 x + 0 y + 0 z = x).
#pragma GCC unroll 9
      for (int j = 0; j < 9; ++j) {
        Gi[j] = gather([j](const LaneInit& li) { return li.gyro_distortion_inv[j]; });
        Ai[j] = gather([j](const LaneInit& li) { return li.accel_distortion_inv[j]; });
      }
    }
    if constexpr (kLever) {
      lx = gather([](const LaneInit& li) { return li.lever_arm_b_m[0]; });
      ly = gather([](const LaneInit& li) { return li.lever_arm_b_m[1]; });
      lz = gather([](const LaneInit& li) { return li.lever_arm_b_m[2]; });
    }
    lat = gather([](const LaneInit& li) { return li.lat_rad; });
    vE = gather([](const LaneInit& li) { return li.v_eb_n_east_mps; });
    vN = gather([](const LaneInit& li) { return li.v_eb_n_north_mps; });
    vEp = vE, vNp = vN;
    qw = gather([](const LaneInit& li) { return li.q_b_n[0]; });
    qx = gather([](const LaneInit& li) { return li.q_b_n[1]; });
    qy = gather([](const LaneInit& li) { return li.q_b_n[2]; });
    qz = gather([](const LaneInit& li) { return li.q_b_n[3]; });
    dthpx = gather([](const LaneInit& li) { return li.dtheta_prev_b_rad[0]; });
    dthpy = gather([](const LaneInit& li) { return li.dtheta_prev_b_rad[1]; });
    dthpz = gather([](const LaneInit& li) { return li.dtheta_prev_b_rad[2]; });
    dvpx = gather([](const LaneInit& li) { return li.dv_prev_b_mps[0]; });
    dvpy = gather([](const LaneInit& li) { return li.dv_prev_b_mps[1]; });
    dvpz = gather([](const LaneInit& li) { return li.dv_prev_b_mps[2]; });
    if constexpr (kLever) {
      ompx = gather([](const LaneInit& li) { return li.omega_ib_b_prev_rad_s[0]; });
      ompy = gather([](const LaneInit& li) { return li.omega_ib_b_prev_rad_s[1]; });
      ompz = gather([](const LaneInit& li) { return li.omega_ib_b_prev_rad_s[2]; });
    }
  }

  // The Earth terms exact at each lane's latitude: sin and cos by their series about the
  // block's reference latitude (Precomputed::ref_lat, ref_sin, ref_cos).
  INSID_AI void anchor(const Precomputed& im, std::size_t blk, double a_m, double e2, double a1e2) {
    const double lref = im.ref_lat[blk], sref = im.ref_sin[blk], cref = im.ref_cos[blk];
    const PN d = lat - lref;
    const PN z = d * d;
    const PN sd =
        fma(d * z, fma(z, fma(z, fma(z, 1.0 / 362880, -1.0 / 5040), 1.0 / 120), -1.0 / 6), d);
    const PN cm1 =
        z * fma(z, fma(z, fma(z, fma(z, -1.0 / 3628800, 1.0 / 40320), -1.0 / 720), 1.0 / 24), -0.5);
    es = sref + fma(sref, cm1, cref * sd);
    ec = cref + fma(cref, cm1, -(sref * sd));
    const PN rs = 1.0 / vsqrt(fma(-e2 * es, es, 1.0));  // 1 / sqrt(1 - e2 sin^2)
    const PN rs2 = rs * rs;
    eRN = a_m * rs;
    eRM = a1e2 * (rs2 * rs);
    ekk = e2 * (es * ec) * rs2;
    ekk3 = 3.0 * ekk;
    edRN = eRN * ekk;
    edRM = eRM * ekk3;
  }

  // Phase A of a step (data and parameters only): the compensated increments, the sculling-
  // corrected velocity increment and the coning-corrected body-rotation quaternion; the step's
  // increments become the lanes' previous ones. `u`: the part of the step the motors ran;
  // `divisor`: the two-sample divisor of the step and the one before (two_sample_divisor).
  INSID_AI Pre<N> compensate_and_rotate(const ImuSample& m, double dt, double u, double divisor) {
    const double t_mid = m.t_s - 0.5 * dt;
    // Compensation (ImuCompensator::compensate): m - (b + b_dot t_mid + b_motor u) dt, then
    // D^-1, u the part of the step the motors ran. Without drift b + b_dot t_mid = b exactly,
    // and b_motor 0 u = 0 adds nothing, so every form gives the fast path's bits.
    PN gx, gy, gz, fx0, fy0, fz0;
    if constexpr (kGeneral) {
      gx = fma(-fma(mgx, u, fma(dgx, t_mid, bgx)), dt, m.dtheta_b_rad.x());
      gy = fma(-fma(mgy, u, fma(dgy, t_mid, bgy)), dt, m.dtheta_b_rad.y());
      gz = fma(-fma(mgz, u, fma(dgz, t_mid, bgz)), dt, m.dtheta_b_rad.z());
      fx0 = fma(-fma(mfx, u, fma(dax, t_mid, bax)), dt, m.dv_b_mps.x());
      fy0 = fma(-fma(mfy, u, fma(day, t_mid, bay)), dt, m.dv_b_mps.y());
      fz0 = fma(-fma(mfz, u, fma(daz, t_mid, baz)), dt, m.dv_b_mps.z());
    } else {
      (void)t_mid;
      gx = fma(-bgx, dt, m.dtheta_b_rad.x());
      gy = fma(-bgy, dt, m.dtheta_b_rad.y());
      gz = fma(-bgz, dt, m.dtheta_b_rad.z());
      fx0 = fma(-bax, dt, m.dv_b_mps.x());
      fy0 = fma(-bay, dt, m.dv_b_mps.y());
      fz0 = fma(-baz, dt, m.dv_b_mps.z());
    }
    PN dthx, dthy, dthz, dvx, dvy, dvz;
    if constexpr (kGeneral) {
      dthx = fma(Gi[2], gz, fma(Gi[1], gy, Gi[0] * gx));
      dthy = fma(Gi[5], gz, fma(Gi[4], gy, Gi[3] * gx));
      dthz = fma(Gi[8], gz, fma(Gi[7], gy, Gi[6] * gx));
      dvx = fma(Ai[2], fz0, fma(Ai[1], fy0, Ai[0] * fx0));
      dvy = fma(Ai[5], fz0, fma(Ai[4], fy0, Ai[3] * fx0));
      dvz = fma(Ai[8], fz0, fma(Ai[7], fy0, Ai[6] * fx0));
    } else {
      dthx = gx, dthy = gy, dthz = gz, dvx = fx0, dvy = fy0, dvz = fz0;
    }
    Pre<N> p;
    // Sculling and rotation (Savage two-sample): f = dv + dth x dv / 2 + (dthp x dv +
    // dvp x dth) / D = dv + ((D/2 dth + dthp) x dv + dvp x dth) / D, D = 12 for equal steps.
    const double weight = 1.0 / divisor;  // 1/12 for equal steps
    const PN ax6 = fma(0.5 * divisor, dthx, dthpx), ay6 = fma(0.5 * divisor, dthy, dthpy),
             az6 = fma(0.5 * divisor, dthz, dthpz);
    p.fx = fma(fma(ay6, dvz, fma(-az6, dvy, fma(dvpy, dthz, -(dvpz * dthy)))), weight, dvx);
    p.fy = fma(fma(az6, dvx, fma(-ax6, dvz, fma(dvpz, dthx, -(dvpx * dthz)))), weight, dvy);
    p.fz = fma(fma(ax6, dvy, fma(-ay6, dvx, fma(dvpx, dthy, -(dvpy * dthx)))), weight, dvz);
    // Coning-corrected body rotation vector (Savage) and its quaternion: cos(x/2) and
    // sin(x/2)/x to degree 6 (truncation < 2e-22 for |x| < 0.06 rad per step).
    const PN phx = fma(fma(dthpy, dthz, -(dthpz * dthy)), weight, dthx);
    const PN phy = fma(fma(dthpz, dthx, -(dthpx * dthz)), weight, dthy);
    const PN phz = fma(fma(dthpx, dthy, -(dthpy * dthx)), weight, dthz);
    const PN th2 = fma(phx, phx, fma(phy, phy, phz * phz));
    p.pw = fma(th2, fma(th2, fma(th2, -1.0 / 46080, 1.0 / 384), -1.0 / 8), 1.0);
    const PN kp = fma(th2, fma(th2, fma(th2, -1.0 / 645120, 1.0 / 3840), -1.0 / 48), 0.5);
    p.px = kp * phx;
    p.py = kp * phy;
    p.pz = kp * phz;
    if constexpr (kLever) {
      p.dthx = dthx;
      p.dthy = dthy;
      p.dthz = dthz;
    }
    dthpx = dthx, dthpy = dthy, dthpz = dthz;
    dvpx = dvx, dvpy = dvy, dvpz = dvz;
    return p;
  }

  // Phase B of a step (the recurrence): velocity, position and attitude from the step's phase
  // A and the shared height and vertical velocity (h_mid, vz_mid at the extrapolated mid-point,
  // h_avg the trapezoidal mid-height), the Earth terms carried to the new latitude.
  INSID_AI void navigate(const Pre<N>& p, const PN& h_mid, const PN& vz_mid, double h_avg,
                         double dt, double wdt) {
    // Extrapolated mid-point (Strapdown::update step 1): lat_mid = lat + em, |em| ~ 1e-8:
    // first-order expansions about the old latitude (the dropped terms, ~1e-16 relative, turn
    // the attitude by < 1e-22 rad per step).
    const PN etn = es / ec;
    const PN T1 = fma(etn, etn, 1.0);  // d tan / d lat
    const PN s_m = fma(ec, em, es);
    const PN c_m = fma(-es, em, ec);
    const PN tan_m = fma(T1, em, etn);
    // Rates are carried multiplied by dt (zeta = (omega_ie + omega_en) dt and the Coriolis
    // increment): dt/(R + h) costs the same division as 1/(R + h).
    const PN Adt = dt / (fma(edRM, em, eRM) + h_mid);  // dt/(RM(lat_mid) + h_mid)
    const PN Bdt = dt / (fma(edRN, em, eRN) + h_mid);  // dt/(RN(lat_mid) + h_mid)
    const PN vEm = fma(0.5, vE - vEp, vE);
    const PN vNm = fma(0.5, vN - vNp, vN);
    const PN zx = -(vNm * Adt);                     // omega_en_x dt (omega_ie_x = 0)
    const PN zen_y = vEm * Bdt;                     // omega_en_y dt
    const PN zen_z = zen_y * tan_m;                 // omega_en_z dt
    const PN zie_y = wdt * c_m, zie_z = wdt * s_m;  // omega_ie dt
    const PN zy = zie_y + zen_y, zz = zie_z + zen_z;

    // u = q f q* (old attitude): t = 2 qv x f, u = f + w t + qv x t.
    const PN qx2 = qx + qx, qy2 = qy + qy, qz2 = qz + qz;
    const PN tx = fma(qy2, p.fz, -(qz2 * p.fy));
    const PN ty = fma(qz2, p.fx, -(qx2 * p.fz));
    const PN tz = fma(qx2, p.fy, -(qy2 * p.fx));
    const PN ux = fma(qw, tx, p.fx) + fma(qy, tz, -(qz * ty));
    const PN uy = fma(qw, ty, p.fy) + fma(qz, tx, -(qx * tz));
    const PN uz = fma(qw, tz, p.fz) + fma(qx, ty, -(qy * tx));
    // (I - 0.5 skew(zeta)) u
    const PN nx = fma(-0.5, fma(zy, uz, -(zz * uy)), ux);
    const PN ny = fma(-0.5, fma(zz, ux, -(zx * uz)), uy);
    // Coriolis: dv = -(2 omega_ie + omega_en) x v_mid dt (gravity is vertical only).
    const PN ay = zy + zie_y, az = zz + zie_z;
    const PN cx = fma(ay, vz_mid, -(az * vNm));
    const PN cy = fma(az, vEm, -(zx * vz_mid));
    // Summed in the reference's order: (v + dv_sf_n) + dv_gcor.
    const PN vE_n = (vE + nx) - cx;
    const PN vN_n = (vN + ny) - cy;

    // Position (trapezoidal, two latitude iterations). 1/(R(lat + d) + h) =
    // 1/(R + h) (1 - R' d/(R + h)) to first order (d ~ 1e-8, the next term ~1e-20); R'/(R + h)
    // is taken as R'/R (relative error h/R in a 1e-10 correction).
    //   x = v_avg_N dt/(RM(lat) + h_avg), first iteration's latitude increment;
    //   lat_n - lat = x (1 - RM' (x/2)/(RM + h)) = x - (3 kk / 2) x^2.
    const PN hC1 = dt * 0.5 / (eRM + h_avg);  // (dt/2)/(RM(lat) + h_avg)
    const PN hE0 = dt * 0.5 / (eRN + h_avg);  // (dt/2)/(RN(lat) + h_avg)
    const PN x = (vN + vN_n) * hC1;
    const PN inc = fma(-0.5 * ekk3 * x, x, x);
    const PN lat_n = lat + inc;
    const PN dl = lat_n - lat;
    const PN e = 0.5 * inc;  // lat_avg2 - lat
    const PN s2 = fma(ec, e, es);
    const PN c2 = fma(-es, e, ec);
    const PN tan2 = fma(T1, e, etn);

    // Attitude: q(-zeta_mid) * q * q(phi), zeta_mid = (omega_ie + omega_en)(lat_avg2, h_avg,
    // v_avg) dt; dt/(R(lat_avg2) + h_avg) = dt/(R + h_avg) (1 - kk' e).
    const PN y = (vE + vE_n) * hE0;
    const PN vEE = fma(-y, ekk * e, y);
    const PN zmx = -fma(-x, ekk3 * e, x);
    const PN zmy = fma(wdt, c2, vEE);
    const PN zmz = fma(vEE, tan2, wdt * s2);
    // cos(|z|/2) and sin(|z|/2)/|z| of the tiny n-frame rotation need |z|^2 only to ~1e-3
    // relative (it enters as 1e-14 corrections): the mid-point rotation's, known early.
    const PN th2z = fma(zx, zx, fma(zy, zy, zz * zz));
    const PN qzw = fma(th2z, -1.0 / 8, 1.0);  // cos(x/2), |x| < 1e-5
    const PN kz = fma(th2z, 1.0 / 48, -0.5);  // -sin(x/2)/x
    const PN pzx = kz * zmx, pzy = kz * zmy, pzz = kz * zmz;
    const PN pw = p.pw, ppx = p.px, ppy = p.py, ppz = p.pz;
    // q(-zeta) * q * q(phi) in the reference's arithmetic order: Eigen's SSE quaternion
    // product as GCC compiles it (t1 = ww*xy + yy*zw etc., the second product of each pair
    // fused), then normalize(). The attitude integrates ~1e5 rotations far below its ulp;
    // another grouping biases the rounding and the attitude drifts ~1e-17 rad per step away
    // from the reference (1e-9 of the fitness after ten minutes).
    const PN rx = fma(pzy, qz, qzw * qx) - fma(-pzx, qw, pzz * qy);
    const PN ry = fma(pzy, qw, qzw * qy) + fma(-pzx, qz, pzz * qx);
    const PN rz = fma(-pzy, qx, qzw * qz) + fma(pzx, qy, pzz * qw);
    const PN rw = fma(-pzy, qy, qzw * qw) - fma(pzx, qx, pzz * qz);
    const PN nqx = fma(ry, ppz, rw * ppx) - fma(-rx, pw, rz * ppy);
    const PN nqy = fma(ry, pw, rw * ppy) + fma(-rx, ppz, rz * ppx);
    const PN nqz = fma(-ry, ppx, rw * ppz) + fma(rx, ppy, rz * pw);
    const PN nw = fma(-ry, ppy, rw * pw) - fma(rx, ppx, rz * ppz);
    // normalize(), exactly as q / RN(sqrt(n2)) but without square root or division: n2 is
    // within a few ulps of 1 (|n2 - 1| = k ulp), where RN(sqrt(1 + e)) = RN(1 + e/2 - e^2/8)
    // is 1 + e/2 rounded with ties toward 1 - sign(e) (the e^2 term only breaks ties): one FMA
    // with a multiplier nudged off 1/2. Then q / (1 + d) = RN(q - q d) (the q d^2 term only
    // matters at exact midpoints). Valid for |n2 - 1| < 2^-32; the products keep
    // |n2 - 1| < 1e-15.
    const PN en = ((nqx * nqx + nqz * nqz) + (nqy * nqy + nw * nw)) - 1.0;
    M<N> pos;
    for (int i = 0; i < N; ++i) pos.c[i] = en.c[i] > 0.0;
    const PN dn = fma(en, blend(pos, bcast<N>(0.5 - 0x1p-21), bcast<N>(0.5 + 0x1p-21)), 1.0) - 1.0;
    qw = fma(-nw, dn, nw);
    qx = fma(-nqx, dn, nqx);
    qy = fma(-nqy, dn, nqy);
    qz = fma(-nqz, dn, nqz);

    // Earth terms carried to the new latitude (first order in dl).
    {
      const PN s_old = es;
      es = fma(ec, dl, s_old);
      ec = fma(-s_old, dl, ec);
      eRN = fma(edRN, dl, eRN);
      eRM = fma(edRM, dl, eRM);
    }

    em = e;  // next step's lat_mid - lat: 1.5 lat_n - 0.5 lat - lat_n
    lat = lat_n;
    vEp = vE;
    vNp = vN;
    vE = vE_n;
    vN = vN_n;
  }

  // C_b_n of the lanes' attitude quaternion.
  struct Dcm {
    PN C00, C01, C02, C10, C11, C12, C20, C21, C22;
  };
  INSID_AI Dcm attitude_matrix() const {
    const PN Tx = 2.0 * qx, Ty = 2.0 * qy, Tz = 2.0 * qz;
    const PN Twx = Tx * qw, Twy = Ty * qw, Twz = Tz * qw;
    const PN Txx = Tx * qx, Txy = Ty * qx, Txz = Tz * qx;
    const PN Tyy = Ty * qy, Tyz = Tz * qy, Tzz = Tz * qz;
    return {1.0 - (Tyy + Tzz), Txy - Twz, Txz + Twy, Txy + Twz,        1.0 - (Txx + Tzz),
            Tyz - Twx,         Txz - Twy, Tyz + Twx, 1.0 - (Txx + Tyy)};
  }

  // v_ant_n = v_eb_n + C_b_n (omega_ib_b x l_b) - omega_ie_n x (C_b_n l_b) of the lanes'
  // current state, omega_ib_b extrapolated to the epoch (oex, oey, oez), the Earth rate wie.
  INSID_AI void antenna(const PN& oex, const PN& oey, const PN& oez, double wie, PN& outE,
                        PN& outN) const {
    const Dcm C = attitude_matrix();
    const V3<N> wl = cross(oex, oey, oez, lx, ly, lz);
    const PN bx = C.C00 * lx + C.C01 * ly + C.C02 * lz;
    const PN by = C.C10 * lx + C.C11 * ly + C.C12 * lz;
    const PN bz = C.C20 * lx + C.C21 * ly + C.C22 * lz;
    const PN Oy = wie * ec, Oz = wie * es;  // Earth rate at the current latitude
    outE = vE + (C.C00 * wl.x + C.C01 * wl.y + C.C02 * wl.z) - (Oy * bz - Oz * by);
    outN = vN + (C.C10 * wl.x + C.C11 * wl.y + C.C12 * wl.z) - (Oz * bx);
  }

  // Windowed fitness: the lanes of `rm` restart after this step (the driver's comment in
  // run_group says from what), their GNSS solution rlat, rgE, rgN and shift rshift (`sm`: the
  // lanes whose shift is not 0); vaE, vaN the antenna velocity of every lane at this step,
  // (oex, oey, oez) the rate at the epoch, h_old the shared height, blk the Earth reference.
  INSID_AI void restart(const M<N>& rm, const M<N>& sm, const PN& rlat, const PN& rgE,
                        const PN& rgN, const PN& rshift, const PN& oex, const PN& oey,
                        const PN& oez, double dt, double h_old, const Precomputed& im,
                        std::size_t blk, double a_m, double e2, double a1e2, double wie,
                        const PN& vaEp, const PN& vaNp, PN& vaE, PN& vaN) {
    // The antenna's acceleration over this step (vaE, vaN at this step, vaEp, vaNp at the one
    // before: the antenna is computed on the step before a restart too).
    const PN aE = (vaE - vaEp) / dt, aN = (vaN - vaNp) / dt;
    // The other lanes keep their state and carried Earth terms bit for bit.
    const PN lat0 = lat, es0 = es, ec0 = ec, eRN0 = eRN, eRM0 = eRM, edRN0 = edRN, edRM0 = edRM,
             ekk0 = ekk, ekk30 = ekk3;
    lat = rlat;
    anchor(im, blk, a_m, e2, a1e2);  // Earth terms at the GNSS latitude (its RM)
    // North shift of the start [m]: shift * vN (GNSS), less the lever arm's north part.
    PN shift_N = rshift * rgN;
    Dcm C{};
    PN bx{}, by{}, bz{};
    if constexpr (kLever) {
      C = attitude_matrix();
      bx = C.C00 * lx + C.C01 * ly + C.C02 * lz;
      by = C.C10 * lx + C.C11 * ly + C.C12 * lz;
      bz = C.C20 * lx + C.C21 * ly + C.C22 * lz;
      shift_N = shift_N - by;
    }
    // lat = lat_GNSS + (shift vN - (C_b_n l_b)_N) / (RM(lat_GNSS) + h), then the Earth terms
    // at the IMU's latitude (a lane with neither effect shifts by exactly 0).
    lat = lat + shift_N / (eRM + h_old);
    anchor(im, blk, a_m, e2, a1e2);
    PN vEs = blend(sm, rgE + rshift * aE, rgE), vNs = blend(sm, rgN + rshift * aN, rgN);
    if constexpr (kLever) {
      // less C_b_n (omega_ib_b x l_b) - omega_ie_n x (C_b_n l_b), omega_ib_b extrapolated to
      // the epoch (oex, oey, oez), Earth rate at the IMU's latitude.
      const V3<N> wl = cross(oex, oey, oez, lx, ly, lz);
      const PN Oy = wie * ec, Oz = wie * es;
      vEs = vEs - ((C.C00 * wl.x + C.C01 * wl.y + C.C02 * wl.z) - (Oy * bz - Oz * by));
      vNs = vNs - ((C.C10 * wl.x + C.C11 * wl.y + C.C12 * wl.z) - (Oz * bx));
    }
    lat = blend(rm, lat, lat0);
    es = blend(rm, es, es0);
    ec = blend(rm, ec, ec0);
    eRN = blend(rm, eRN, eRN0);
    eRM = blend(rm, eRM, eRM0);
    edRN = blend(rm, edRN, edRN0);
    edRM = blend(rm, edRM, edRM0);
    ekk = blend(rm, ekk, ekk0);
    ekk3 = blend(rm, ekk3, ekk30);
    vE = blend(rm, vEs, vE);
    vN = blend(rm, vNs, vN);
    vEp = blend(rm, vE, vEp);
    vNp = blend(rm, vN, vNp);
    em = blend(rm, bcast<N>(0.0), em);
    PN vaEs = vE, vaNs = vN;
    if constexpr (kLever) antenna(oex, oey, oez, wie, vaEs, vaNs);
    vaE = blend(rm, vaEs, vaE);
    vaN = blend(rm, vaNs, vaN);
  }
};
// The kernel: N vectors of W lanes from `lanes` (N * W entries), whole navigation run. The
// driver of the phases (Group): blocks of steps, phase A over a block, the Earth anchors, phase
// B step by step with the shared height, the antenna velocity, the GNSS epochs (residuals and
// Eq. 15) and the window restarts.
template <int N, bool kGeneral, bool kLever>
void run_group(const NavigationProblem& nav, const Precomputed& im, LaneInit* const* lanes,
               bool sum_squares, double* acc_out) {
  constexpr int L = N * W;
  using PN = P<N>;
  const Dataset& ds = nav.dataset();
  const std::vector<ImuSample>& imu = ds.imu;
  const std::vector<double>& href = nav.height_reference_m();
  const std::vector<double>& vuref = nav.vertical_velocity_reference_mps();
  const EarthModel& earth = ds.meta.earth;
  const double a_m = earth.ellipsoid.a_m;
  const double e2 = earth.ellipsoid.e2();
  const double a1e2 = a_m * (1.0 - e2);
  const double wie = earth.omega_ie_rad_s;
  const std::size_t nb = im.nb, n = im.n;

  Group<N, kGeneral, kLever> g(lanes);
  // vaEp, vaNp the antenna velocity at the step before [m/s]; acc the running Eq. 15 sum.
  PN vaEp = gather_lanes<N>(lanes, [](const LaneInit& li) { return li.v_ant_n_east_mps; });
  PN vaNp = gather_lanes<N>(lanes, [](const LaneInit& li) { return li.v_ant_n_north_mps; });
  PN acc = gather_lanes<N>(lanes, [](const LaneInit& li) { return li.eq15_sum_at_start; });

  // GNSS epochs: one shared schedule when every lane has the same event list and position,
  // else per-lane cursors with masked accumulation (same arithmetic per lane).
  bool uniform = true;
  for (int l = 1; l < L; ++l)
    uniform =
        uniform && lanes[l]->events == lanes[0]->events && lanes[l]->cursor == lanes[0]->cursor;
  std::vector<double>* res[L];
  bool any_res = false;
  for (int l = 0; l < L; ++l) {
    res[l] = lanes[l]->residuals;
    any_res = any_res || res[l] != nullptr;
  }
  const Event* uev = lanes[0]->events->data();
  std::size_t ucur = lanes[0]->cursor;
  const std::size_t uend = lanes[0]->events->size();
  const Event* lev[L];
  std::size_t lcur[L], lend[L];
  for (int l = 0; l < L; ++l) {
    lev[l] = lanes[l]->events->data();
    lcur[l] = lanes[l]->cursor;
    lend[l] = lanes[l]->events->size();
  }
  constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();
  auto lane_next = [&](int l) { return lcur[l] < lend[l] ? lev[l][lcur[l]].step : kNever; };
  auto next_event_step = [&]() {
    if (uniform) return ucur < uend ? uev[ucur].step : kNever;
    std::int64_t m = kNever;
    for (int l = 0; l < L; ++l) m = std::min(m, lane_next(l));
    return m;
  };
  std::int64_t next_step = next_event_step();

  // Residual and Eq. 15 term of the INS antenna velocity interpolated to an epoch.
  auto term = [&](const PN& vEnow, const PN& vNnow, const PN& w, const PN& gE, const PN& gN, PN& rE,
                  PN& rN) __attribute__((always_inline)) {
    rE = fma(w, vEnow - vaEp, vaEp) - gE;
    rN = fma(w, vNnow - vaNp, vaNp) - gN;
    const PN d2 = fma(rE, rE, rN * rN);
    return sum_squares ? d2 : vsqrt(d2);
  };
  auto emit = [&](std::int64_t k, const PN& vEnow, const PN& vNnow) {
    PN rE, rN;
    if (uniform) {
      while (ucur < uend && uev[ucur].step == k) {
        const Event& ev = uev[ucur++];
        acc = acc + term(vEnow, vNnow, bcast<N>(ev.w), bcast<N>(ev.gE), bcast<N>(ev.gN), rE, rN);
        if (any_res)
          for (int l = 0; l < L; ++l)
            if (res[l]) {
              (*res[l])[2 * ev.epoch] = lane(rE, l);
              (*res[l])[2 * ev.epoch + 1] = lane(rN, l);
            }
      }
      return;
    }
    for (;;) {
      PN w{}, gE{}, gN{};
      M<N> m{};
      bool any = false;
      for (int l = 0; l < L; ++l) {
        if (lane_next(l) != k) continue;
        const Event& ev = lev[l][lcur[l]];
        w.c[l / W][l % W] = ev.w;
        gE.c[l / W][l % W] = ev.gE;
        gN.c[l / W][l % W] = ev.gN;
        m.c[l / W][l % W] = -1;
        any = true;
      }
      if (!any) break;
      const PN t = term(vEnow, vNnow, w, gE, gN, rE, rN);
      acc = blend(m, acc + t, acc);
      for (int l = 0; l < L; ++l) {
        if (!m.c[l / W][l % W]) continue;
        const Event& ev = lev[l][lcur[l]++];
        if (res[l]) {
          (*res[l])[2 * ev.epoch] = lane(rE, l);
          (*res[l])[2 * ev.epoch + 1] = lane(rN, l);
        }
      }
    }
  };

  // The step splits into a part that depends only on the data and the lane's parameters
  // (compensation, sculling, coning, the body-rotation quaternion: phase A) and the recurrence
  // (phase B). Phase A runs over a block of steps into a small buffer (L1-resident), so that
  // phase B's long dependency chains are interleaved with fewer, independent operations and
  // fewer registers are live.
  constexpr int kBlock = 16;
  static_assert(((1 << kAnchorShift) % kBlock) == 0, "anchors fall on block starts");
  Pre<N> pre[kBlock];

  double h_old = im.h0, h_pv = im.h0, vz_old = im.vz0, vz_pv = im.vz0;
  // Interval of the increment before row k (the seed's before the first navigated row), for the
  // two-sample weights (nav/mechanization.h, two_sample_divisor).
  auto previous_dt = [&](std::size_t k) {
    return k >= 2 ? imu[k - 1].t_s - imu[k - 2].t_s : 1.0 / ds.meta.imu_rate_hz;
  };
  // Windowed fitness: each lane's window starts (its latency's StartList); `fresh`: the lanes
  // restarted after the step before, whose height and vertical velocity are not extrapolated to
  // the mid-point (the reference's previous state is the restart state).
  const StartList* lst[L];
  std::size_t scur[L];
  for (int l = 0; l < L; ++l) {
    lst[l] = lanes[l]->starts;
    scur[l] = 0;
  }
  auto lane_next_start = [&](int l) {
    return scur[l] < lst[l]->size() ? (*lst[l])[scur[l]].step : kNever;
  };
  auto next_start_step = [&]() {
    std::int64_t m = kNever;
    for (int l = 0; l < L; ++l) m = std::min(m, lane_next_start(l));
    return m;
  };
  std::int64_t next_restart = next_start_step();
  M<N> fresh{};
  bool any_fresh = false;
  for (std::size_t k0 = nb; k0 < n; k0 += kBlock) {
    const int kb = static_cast<int>(std::min<std::size_t>(kBlock, n - k0));

    // --- Phase A.
    for (int j = 0; j < kb; ++j) {
      const std::size_t k = k0 + static_cast<std::size_t>(j);
      const double dt = imu[k].t_s - imu[k - 1].t_s;
      double u = 0.0;  // the part of the step the motors ran
      if constexpr (kGeneral) u = nav.motor_on(k);
      pre[j] = g.compensate_and_rotate(imu[k], dt, u, two_sample_divisor(previous_dt(k), dt));
    }

    if (((k0 - nb) & ((std::size_t{1} << kAnchorShift) - 1)) == 0)
      g.anchor(im, (k0 - nb) >> kRefShift, a_m, e2, a1e2);

    // --- Phase B.
    for (int j = 0; j < kb; ++j) {
      const std::size_t k = k0 + static_cast<std::size_t>(j);
      const Pre<N>& p = pre[j];
      const double dt = imu[k].t_s - imu[k - 1].t_s;
      PN h_mid = bcast<N>(1.5 * h_old - 0.5 * h_pv);
      PN vz_mid = bcast<N>(1.5 * vz_old - 0.5 * vz_pv);
      if (any_fresh) {
        h_mid = blend(fresh, bcast<N>(1.5 * h_old - 0.5 * h_old), h_mid);
        vz_mid = blend(fresh, bcast<N>(1.5 * vz_old - 0.5 * vz_old), vz_mid);
        any_fresh = false;
      }
      // Trapezoidal mid-height, shared: the reference's per-candidate h_avg differs by a
      // quarter step of the candidate's unaided vertical velocity error (< 1e-4 m: 2e-11 of R,
      // zero-mean).
      const double h_avg = 0.5 * (h_old + (h_old + 0.5 * (vz_old + vuref[k]) * dt));
      g.navigate(p, h_mid, vz_mid, h_avg, dt, wie * dt);
      // Height and vertical velocity aided: shared.
      h_pv = h_old;
      h_old = href[k];
      vz_pv = vz_old;
      vz_old = vuref[k];

      // Antenna velocity (lever arm) and the GNSS epochs of this step.
      const auto kk64 = static_cast<std::int64_t>(k);
      const bool restart_here = kk64 == next_restart;
      PN vaE = g.vE, vaN = g.vN;
      PN oex{}, oey{}, oez{};
      if constexpr (kLever) {
        const double inv_dt = 1.0 / dt;
        const PN omx = p.dthx * inv_dt, omy = p.dthy * inv_dt, omz = p.dthz * inv_dt;
        if (next_step <= kk64 + 1 || next_restart <= kk64 + 1) {
          oex = 1.5 * omx - 0.5 * g.ompx;
          oey = 1.5 * omy - 0.5 * g.ompy;
          oez = 1.5 * omz - 0.5 * g.ompz;
          g.antenna(oex, oey, oez, wie, vaE, vaN);
        }
        g.ompx = omx, g.ompy = omy, g.ompz = omz;
      }
      if (next_step == kk64) {
        if (uniform && !any_res) {
          // The common case inline: every lane compares with the same epochs.
          do {
            const Event& ev = uev[ucur++];
            PN rE, rN;
            acc = acc + term(vaE, vaN, bcast<N>(ev.w), bcast<N>(ev.gE), bcast<N>(ev.gN), rE, rN);
          } while (ucur < uend && uev[ucur].step == kk64);
        } else {
          emit(kk64, vaE, vaN);
        }
        next_step = next_event_step();
      }
      if (restart_here) {
        // Windowed fitness (nav/fitness.h, "Windowed fitness", "Start state"): the lanes whose
        // window start follows this step (the boundary's antenna time; their epochs up to this
        // step closed the window) restart as NavigationProblem::run does: from the GNSS solution
        // at the boundary shifted by the start's shift (velocity with the antenna's INS
        // acceleration over this step), less the lever arm (NavigationProblem::set_from_gnss),
        // attitude and coning/sculling memory carried on, previous state = restart state (no
        // mid-point extrapolation: em = 0, vEp = vE, `fresh` for h and vU), Earth terms exact at
        // the new latitude. The other lanes are left as they are, bit for bit.
        M<N> rm{}, sm{};  // lanes restarting here; those with a non-zero shift
        PN rlat = g.lat, rgE{}, rgN{}, rshift{};
        for (int l = 0; l < L; ++l) {
          if (lane_next_start(l) != kk64) continue;
          const Start& st = (*lst[l])[scur[l]++];
          rm.c[l / W][l % W] = -1;
          sm.c[l / W][l % W] = st.shift_s != 0.0 ? -1 : 0;
          rlat.c[l / W][l % W] = st.lat_rad;
          rgE.c[l / W][l % W] = st.vE_mps;
          rgN.c[l / W][l % W] = st.vN_mps;
          rshift.c[l / W][l % W] = st.shift_s;
        }
        next_restart = next_start_step();
        g.restart(rm, sm, rlat, rgE, rgN, rshift, oex, oey, oez, dt, h_old, im,
                  (k - nb) >> kRefShift, a_m, e2, a1e2, wie, vaEp, vaNp, vaE, vaN);
        fresh = rm;
        any_fresh = true;
      }
      vaEp = vaE;
      vaNp = vaN;
    }
  }
  // Epochs past the end of the data (latency < 0): clamped to the last state.
  if (next_step == static_cast<std::int64_t>(n)) emit(static_cast<std::int64_t>(n), vaEp, vaNp);

  for (int l = 0; l < L; ++l) acc_out[l] = lane(acc, l);
}

// Two vectors per group with AVX-512's 32 registers; one where a vector takes 2 or 4 of 16
// registers and a two-vector group spills (results/perf/README.md, "CPU dispatch": 2.75x native
// at K = 16 vs 1.88x at K = 8).
#if defined(INSID_K_AVX512)
constexpr int kPlannedChains = 2;
#else
constexpr int kPlannedChains = 1;
#endif

// A two-vector group on a path that plans one vector per group (a test's explicit grouping, or
// a request for this path from a program whose own path plans two): its two vectors run one
// after the other. A lane's arithmetic does not depend on its group (see the top of the file),
// so the result is the same to the bit, and these paths compile four instantiations of
// run_group instead of eight (compile time: 21 s for the baseline object instead of 58 s, 12 s
// for the AVX2 one instead of 29 s).
template <bool kGeneral, bool kLever>
void run_pair_as_singles(const NavigationProblem& nav, const Precomputed& im,
                         LaneInit* const* lanes, bool sum_squares, double* acc_out) {
  run_group<1, kGeneral, kLever>(nav, im, lanes, sum_squares, acc_out);
  run_group<1, kGeneral, kLever>(nav, im, lanes + W, sum_squares, acc_out + W);
}

template <int N>
GroupFn pick(bool general, bool lever) {
  if constexpr (N == 2 && kPlannedChains == 1) {
    if (general)
      return lever ? &run_pair_as_singles<true, true> : &run_pair_as_singles<true, false>;
    return lever ? &run_pair_as_singles<false, true> : &run_pair_as_singles<false, false>;
  } else {
    if (general) return lever ? &run_group<N, true, true> : &run_group<N, true, false>;
    return lever ? &run_group<N, false, true> : &run_group<N, false, false>;
  }
}

GroupFn pick_group(int n_vectors, bool general, bool lever) {
  return n_vectors == 1 ? pick<1>(general, lever) : pick<2>(general, lever);
}

// The fast search fitness's loop (batch_kernel.h, SumNormsFn): kSumNormsLanes = 2 vectors.
static_assert(kSumNormsLanes == 2 * W);
INSID_AI P<2> load_lanes(const double* p) {
  P<2> r;
  std::memcpy(&r, p, sizeof r);
  return r;
}

// The node's x-dependent part, east and north: sum_p coeff[c][p] phi[p] from 0, in p order.
INSID_AI void node_values(const double* coeff, std::size_t features, const double* phi, P<2>& vE,
                          P<2>& vN) {
  vE = bcast<2>(0.0);
  vN = bcast<2>(0.0);
  for (std::size_t p = 0; p < features; ++p) {
    const P<2> ph = load_lanes(phi + p * kSumNormsLanes);
    vE = vE + coeff[p] * ph;
    vN = vN + coeff[features + p] * ph;
  }
}

void sum_norms(const double* r0, const double* w, const double* coeff, std::size_t features,
               const double* phi, const SumBlock* blocks, std::size_t n_blocks, double* acc) {
  P<2> sum = load_lanes(acc), aE = bcast<2>(0.0), aN = aE, bE = aE, bN = aE;
  std::size_t have_a = static_cast<std::size_t>(-1);
  for (std::size_t j = 0; j < n_blocks; ++j) {
    const SumBlock& block = blocks[j];
    if (have_a != block.node_a)
      node_values(coeff + 2 * features * block.node_a, features, phi, aE, aN);
    node_values(coeff + 2 * features * block.node_b, features, phi, bE, bN);
    const P<2> dE = bE - aE, dN = bN - aN;
    for (std::size_t e = block.first_epoch; e < block.end_epoch; ++e) {
      const P<2> rE = r0[2 * e] + (aE + w[e] * dE);
      const P<2> rN = r0[2 * e + 1] + (aN + w[e] * dN);
      sum = sum + vsqrt(rE * rE + rN * rN);
    }
    aE = bE;
    aN = bN;
    have_a = block.node_b;
  }
  std::memcpy(acc, &sum, sizeof sum);
}

}  // namespace
extern const KernelPath kPath = {INSID_KERNEL_NAME, INSID_KERNEL_DESCRIPTION, kPlannedChains,
                                 &pick_group, &sum_norms};

}  // namespace insid::INSID_KERNEL_NS
