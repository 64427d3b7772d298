// The batched kernel's instruction-set paths: what kernel/batch_fitness.cc (compiled for
// the program's baseline instruction set) and kernel/batch_kernel.cc (compiled once per path)
// share.
//
// One program holds every path: batch_kernel.cc is compiled three times (AVX-512, AVX2 + FMA,
// baseline x86-64; kernel/CMakeLists.txt), and the first use picks one with the CPU checks and
// INSID_CPU (kernel/cpu_path.h). Instruction sets never mix through inline functions: every header
// is read before batch_kernel.cc switches the instruction set (`#pragma GCC target`), so each
// inline function a header defines (std, Eigen, insid) is baseline code wherever the linker keeps
// its copy; GCC inlines such a function into a kernel function (a subset of its instruction set)
// but never the other way. The kernel's own functions carry the path's instruction set and live
// in a namespace of their own (insid::kernel_avx512, ...), internal to their object except the
// one KernelPath object each exports. `ctest -R kernel_isa_confined` checks the linked program:
// no function outside those namespaces uses an instruction beyond the baseline.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernel/batch_lanes.h"
#include "nav/fitness.h"

namespace insid::batch_kernel {

constexpr int W = kBatchLanes;
constexpr int kRefShift = 6;     // reference latitude every 64 IMU steps
constexpr int kAnchorShift = 5;  // exact Earth terms every 32 IMU steps

// One GNSS epoch compared: emitted at IMU index `step` (nav_begin - 1: before the first step,
// clamped to the start; n_imu: after the last step, clamped to the end), interpolating the INS
// velocity between the states at step - 1 and step with weight w.
struct Event {
  std::int64_t step;   ///< IMU index after whose state the epoch is compared
  double w;            ///< interpolation weight between the states at step - 1 and step [1]
  double gE, gN;       ///< GNSS velocity, east and north of n = ENU [m/s]
  std::int64_t epoch;  ///< index of the compared epoch (residual slots 2 epoch, 2 epoch + 1)
};
using EventList = std::vector<Event>;

// The window starts of one latency (NavigationProblem::window_starts) with their GNSS values:
// after IMU step `step`, from the GNSS solution at the boundary shifted by shift_s.
struct Start {
  std::int64_t step;  ///< IMU index of the step the restart follows
  double lat_rad;     ///< GNSS latitude at the boundary [rad]
  double vE_mps;      ///< GNSS velocity at the boundary, east component of n = ENU [m/s]
  double vN_mps;      ///< north component [m/s]
  double shift_s;     ///< start time minus the boundary's antenna time [s]
};
using StartList = std::vector<Start>;

// Everything one lane needs, set up in scalar code from the candidate (O(1) except the
// events and window starts of a non-zero latency).
struct LaneInit {
  double gyro_distortion_inv[9];        ///< (I + S_g + M_g)^-1, row-major [1]
  double accel_distortion_inv[9];       ///< (I + S_a + M_a)^-1, row-major [1]
  bool general = false;                 ///< distortion, bias drift or motor offset present
  double gyro_bias_b_rad_s[3];          ///< gyro bias at t = 0, body FRD [rad/s]
  double gyro_bias_drift_b_rad_s2[3];   ///< its linear drift [rad/s^2]
  double accel_bias_b_mps2[3];          ///< accelerometer bias at t = 0, body FRD [m/s^2]
  double accel_bias_drift_b_mps3[3];    ///< its linear drift [m/s^3]
  double gyro_motor_offset_b_rad_s[3];  ///< gyro offset while the motors run [rad/s]
  double accel_motor_offset_b_mps2[3];  ///< accelerometer offset while the motors run [m/s^2]
  double lat_rad;                       ///< geodetic latitude at the navigation start [rad]
  double v_eb_n_east_mps;               ///< INS velocity, east component of n = ENU [m/s]
  double v_eb_n_north_mps;              ///< INS velocity, north component [m/s]
  double q_b_n[4];                      ///< attitude quaternion b -> n: w, x, y, z [1]
  double dtheta_prev_b_rad[3];          ///< compensated angle increment of the step before [rad]
  double dv_prev_b_mps[3];              ///< compensated velocity increment of the step before [m/s]
  double omega_ib_b_prev_rad_s[3];      ///< mean angular rate over the step before [rad/s]
  double lever_arm_b_m[3];              ///< GNSS antenna relative to the IMU, body FRD [m]
  bool lever = false;                   ///< lever arm non-zero
  double v_ant_n_east_mps;              ///< antenna velocity at the navigation start, east [m/s]
  double v_ant_n_north_mps;             ///< antenna velocity at the navigation start, north [m/s]
  double eq15_sum_at_start = 0.0;  ///< epochs clamped to the start, already summed (Eq. 15 terms)
  const EventList* events = nullptr;
  std::size_t cursor = 0;             ///< first event not yet emitted
  const StartList* starts = nullptr;  ///< its window starts (windowed fitness)
  std::vector<double>* residuals = nullptr;
};

/// What BatchFitness precomputes per problem (its constructor, batch_fitness.cc).
struct Precomputed {
  std::size_t nb = 0, n = 0;
  std::vector<double> ref_lat, ref_sin, ref_cos;
  EventList events0;  // latency 0
  StartList starts0;  // latency 0
  double h0 = 0.0, vz0 = 0.0;
  std::size_t n_epochs = 0;
};

/// One group of N vectors (N * W lanes from `lanes`) over the whole navigation run; writes each
/// lane's Eq. 15 or sum-of-squares to acc_out.
using GroupFn = void (*)(const NavigationProblem& nav, const Precomputed& pre,
                         LaneInit* const* lanes, bool sum_squares, double* acc_out);

/// Candidates the fast search fitness sums together (identification/search_fitness.h).
constexpr int kSumNormsLanes = 16;
/// Epochs [first_epoch, end_epoch) of the fast search fitness, interpolated between two nodes.
struct SumBlock {
  std::size_t first_epoch, end_epoch;
  std::size_t node_a, node_b;
};
/// The fast search fitness's loop over its blocks, for kSumNormsLanes candidates at once:
///   v_c(node)[k] = sum_p coeff[node][c][p] phi[p][k]          (the model's x-dependent part),
///   acc[k] += sum over e in [first, end) of |(r0[2e] + (a_E[k] + w[e] (b_E[k] - a_E[k])),
///                                             r0[2e + 1] + (a_N[k] + w[e] (b_N[k] - a_N[k])))|
/// with a = v(node_a), b = v(node_b); coeff holds 2 * features values per node (east, then
/// north), phi features * kSumNormsLanes. Unfused on every path (the file is compiled with
/// -ffp-contract=off), so every path gives the same bits.
using SumNormsFn = void (*)(const double* r0, const double* w, const double* coeff,
                            std::size_t features, const double* phi, const SumBlock* blocks,
                            std::size_t n_blocks, double* acc);
/// One instruction-set path of the kernel (one compilation of batch_kernel.cc).
struct KernelPath {
  const char* name;         ///< INSID_CPU value: avx512, avx2, baseline (native: not dispatching)
  const char* description;  ///< for --version and every result's build block (`cpu_path`)
  int planned_chains;       ///< vectors per group BatchFitness::plan_groups plans on this path
  GroupFn (*pick)(int n_vectors, bool general, bool lever);  ///< n_vectors 1 or 2
  SumNormsFn sum_norms;  ///< the fast search fitness's loop on this path
};

}  // namespace insid::batch_kernel

// The paths this build holds (kernel/CMakeLists.txt defines the ones compiled in).
namespace insid::kernel_avx512 {
extern const batch_kernel::KernelPath kPath;
}
namespace insid::kernel_avx2 {
extern const batch_kernel::KernelPath kPath;
}
namespace insid::kernel_baseline {
extern const batch_kernel::KernelPath kPath;
}
namespace insid::kernel_native {
extern const batch_kernel::KernelPath kPath;
}
