// Batched multi-candidate fitness kernel; see batch_fitness.h. This file is the kernel's scalar
// side, compiled for the program's instruction set: the precomputation, each lane's set-up
// (following NavigationProblem::run) and the grouping over threads. The vector loop is
// kernel/batch_kernel.cc, compiled once per instruction-set path (kernel/batch_kernel.h); the path
// is chosen at first use (kernel/cpu_path.h).
#include "kernel/batch_fitness.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <mutex>
#include <stdexcept>

#include <Eigen/Geometry>

#include "base/huge_pages.h"
#include "data/gnss_interpolation.h"
#include "kernel/batch_kernel.h"
#include "kernel/cpu_path.h"

namespace insid {

using batch_kernel::Event;
using batch_kernel::EventList;
using batch_kernel::kRefShift;
using batch_kernel::LaneInit;
using batch_kernel::Start;
using batch_kernel::StartList;

namespace {

// Body rotation per IMU interval covered by the rotation-vector series to degree 6 (truncation
// below 2e-22 there): 6 rad/s at 100 Hz.
constexpr double kMaxStepRotation = 0.06;

// The epochs and weights NavigationProblem::run uses for a given latency, in its order.
EventList make_events(const NavigationProblem& nav, double latency) {
  const Dataset& ds = nav.dataset();
  const std::vector<std::size_t>& idx = nav.epoch_gnss_indices();
  const std::size_t n_epochs = idx.size();
  const std::size_t nb = nav.nav_begin();
  EventList out;
  out.reserve(n_epochs);
  auto epoch_time = [&](std::size_t e) { return ds.gnss[idx[e]].t_s - latency; };
  std::size_t e = 0;
  auto push = [&](std::int64_t step, double w) {
    const GnssSample& g = ds.gnss[idx[e]];
    out.push_back({step, w, g.v_eb_n_mps.x(), g.v_eb_n_mps.y(), static_cast<std::int64_t>(e)});
    ++e;
  };
  double t_prev = ds.imu[nb - 1].t_s;
  while (e < n_epochs && epoch_time(e) <= t_prev) push(static_cast<std::int64_t>(nb) - 1, 0.0);
  for (std::size_t k = nb; k < ds.imu.size(); ++k) {
    const double t = ds.imu[k].t_s;
    while (e < n_epochs && epoch_time(e) <= t) {
      const double w = (epoch_time(e) - t_prev) / (t - t_prev);
      push(static_cast<std::int64_t>(k), w);
    }
    t_prev = t;
  }
  while (e < n_epochs) push(static_cast<std::int64_t>(ds.imu.size()), 0.0);
  return out;
}

// The window starts of one latency (NavigationProblem::window_starts) with their GNSS values.
StartList make_starts(const NavigationProblem& nav, double latency) {
  StartList out;
  for (const WindowStart& w : nav.window_starts(latency)) {
    const WindowRestart& r = nav.window_restarts()[w.restart];
    out.push_back(
        {static_cast<std::int64_t>(w.imu_index), r.lat_rad, r.vE_mps, r.vN_mps, w.shift_s});
  }
  return out;
}

}  // namespace

struct BatchFitness::Impl : batch_kernel::Precomputed {};

namespace {

// Scalar set-up of one lane, following NavigationProblem::run line by line.
void setup_lane(const NavigationProblem& nav, const SensorErrors& c, const EventList* events,
                const StartList* starts, bool sum_squares, std::vector<double>* residuals,
                LaneInit& li) {
  const Dataset& ds = nav.dataset();
  const EarthModel& earth = ds.meta.earth;
  const std::size_t nb = nav.nav_begin();
  const ImuCompensator compensator(c);
  const Eigen::Matrix3d C0 = nav.initial_attitude(c);
  ImuSample prev = ds.imu[nb - 1];
  const double t_before = nb >= 2 ? ds.imu[nb - 2].t_s : prev.t_s - 1.0 / ds.meta.imu_rate_hz;
  compensator.compensate(prev.t_s, prev.t_s - t_before, prev.dtheta_b_rad, prev.dv_b_mps,
                         nav.motor_on(nb - 1));
  const Eigen::Vector3d omega_mid_prev = prev.dtheta_b_rad / (prev.t_s - t_before);
  const NavState s0 = nav.initial_state(C0, c, prev, prev.t_s - t_before);

  const Eigen::Matrix3d Gi = c.gyro.distortion().inverse();
  const Eigen::Matrix3d Ai = c.accel.distortion().inverse();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      li.gyro_distortion_inv[3 * i + j] = Gi(i, j);
      li.accel_distortion_inv[3 * i + j] = Ai(i, j);
    }
  li.general = !(Gi == Eigen::Matrix3d::Identity() && Ai == Eigen::Matrix3d::Identity()) ||
               !c.gyro.bias_drift.isZero(0) || !c.accel.bias_drift.isZero(0) ||
               (!ds.meta.motors.empty() &&
                (!c.gyro.motor_offset.isZero(0) || !c.accel.motor_offset.isZero(0)));
  for (int i = 0; i < 3; ++i) {
    li.gyro_bias_b_rad_s[i] = c.gyro.bias[i];
    li.gyro_bias_drift_b_rad_s2[i] = c.gyro.bias_drift[i];
    li.accel_bias_b_mps2[i] = c.accel.bias[i];
    li.accel_bias_drift_b_mps3[i] = c.accel.bias_drift[i];
    li.gyro_motor_offset_b_rad_s[i] = c.gyro.motor_offset[i];
    li.accel_motor_offset_b_mps2[i] = c.accel.motor_offset[i];
    li.lever_arm_b_m[i] = c.lever_arm_b_m[i];
  }
  li.lever = !c.lever_arm_b_m.isZero(0);
  li.lat_rad = s0.lat_rad;
  li.v_eb_n_east_mps = s0.v_eb_n.x();
  li.v_eb_n_north_mps = s0.v_eb_n.y();
  li.q_b_n[0] = s0.q_b_n.w();
  li.q_b_n[1] = s0.q_b_n.x();
  li.q_b_n[2] = s0.q_b_n.y();
  li.q_b_n[3] = s0.q_b_n.z();

  for (int i = 0; i < 3; ++i) {
    li.dtheta_prev_b_rad[i] = prev.dtheta_b_rad[i];
    li.dv_prev_b_mps[i] = prev.dv_b_mps[i];
    li.omega_ib_b_prev_rad_s[i] = omega_mid_prev[i];
  }
  Eigen::Vector3d v_ant = s0.v_eb_n;
  if (li.lever) {
    const Eigen::Vector3d& l_b = c.lever_arm_b_m;
    const Eigen::Matrix3d C = s0.q_b_n.toRotationMatrix();
    v_ant = s0.v_eb_n + C * omega_mid_prev.cross(l_b) - earth.omega_ie_n(s0.lat_rad).cross(C * l_b);
  }
  li.v_ant_n_east_mps = v_ant.x();
  li.v_ant_n_north_mps = v_ant.y();

  li.events = events;
  li.starts = starts;
  li.residuals = residuals;
  li.eq15_sum_at_start = 0.0;
  li.cursor = 0;
  const auto start_step = static_cast<std::int64_t>(nb) - 1;
  while (li.cursor < events->size() && (*events)[li.cursor].step == start_step) {
    const Event& ev = (*events)[li.cursor++];
    const double rE = li.v_ant_n_east_mps - ev.gE;
    const double rN = li.v_ant_n_north_mps - ev.gN;
    if (residuals) {
      (*residuals)[2 * ev.epoch] = rE;
      (*residuals)[2 * ev.epoch + 1] = rN;
    }
    const double d2 = rE * rE + rN * rN;
    li.eq15_sum_at_start += sum_squares ? d2 : std::sqrt(d2);
  }
}

}  // namespace

BatchFitness::BatchFitness(std::shared_ptr<const NavigationProblem> problem)
    : problem_(std::move(problem)) {
  if (!problem_) throw std::invalid_argument("BatchFitness: null problem");
  const NavigationProblem& nav = *problem_;
  const Dataset& ds = nav.dataset();
  auto impl = std::make_shared<Impl>();
  impl->nb = nav.nav_begin();
  impl->n = ds.imu.size();
  impl->n_epochs = nav.num_epochs();
  if (nav.alignment_window().count == 0 && nav.initial_attitude_source().depends_on_candidate())
    reason_ = "no alignment window (align_s = 0)";
  double max_rot = 0.0;
  for (std::size_t k = impl->nb; k < impl->n && reason_.empty(); ++k) {
    if (!(ds.imu[k].t_s > ds.imu[k - 1].t_s))
      reason_ = "IMU time stamps not increasing at row " + std::to_string(k);
    max_rot = std::max(max_rot, ds.imu[k].dtheta_b_rad.norm());
  }
  if (reason_.empty() && !(max_rot < kMaxStepRotation))
    reason_ = "body rotation of " + std::to_string(max_rot) + " rad in one IMU interval (> " +
              std::to_string(kMaxStepRotation) + ")";
  if (reason_.empty()) {
    const std::size_t steps = impl->n - impl->nb;
    const std::size_t blocks = (steps >> kRefShift) + 1;
    impl->ref_lat.resize(blocks);
    impl->ref_sin.resize(blocks);
    impl->ref_cos.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b) {
      const std::size_t k = std::min(impl->nb + (b << kRefShift), impl->n - 1);
      const double lat = interpolate_gnss(ds.gnss, ds.imu[k].t_s).lat_rad;
      impl->ref_lat[b] = lat;
      impl->ref_sin[b] = std::sin(lat);
      impl->ref_cos[b] = std::cos(lat);
    }
    impl->events0 = make_events(nav, 0.0);
    impl->starts0 = make_starts(nav, 0.0);
    const NavState s0 = nav.initial_state(Eigen::Matrix3d::Identity());
    impl->h0 = s0.h_m;
    impl->vz0 = s0.v_eb_n.z();
  }
  impl_ = std::move(impl);
}

std::shared_ptr<const BatchFitness> BatchFitness::shared(
    const std::shared_ptr<const NavigationProblem>& problem) {
  static std::mutex mutex;
  static std::map<const NavigationProblem*, std::weak_ptr<const BatchFitness>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  for (auto it = cache.begin(); it != cache.end();)
    it = it->second.expired() ? cache.erase(it) : std::next(it);
  // A live kernel holds its problem, so a live entry's address cannot have been reused.
  if (auto it = cache.find(problem.get()); it != cache.end())
    if (auto kernel = it->second.lock()) return kernel;
  auto kernel = std::make_shared<const BatchFitness>(problem);
  cache[problem.get()] = kernel;
  return kernel;
}

int BatchFitness::planned_chains() { return cpu_path().planned_chains; }

std::vector<int> BatchFitness::plan_groups(int num_vectors, int threads) {
  std::vector<int> groups;
  if (num_vectors <= 0) return groups;
  threads = std::max(threads, 1);
  const int chains = planned_chains();
  int g = (num_vectors + chains - 1) / chains;
  if (threads > 1) {
    g = std::max(g, std::min(num_vectors, threads));
    g = std::min(num_vectors, ((g + threads - 1) / threads) * threads);
  }
  for (int i = 0; i < g; ++i) groups.push_back(num_vectors / g + (i < num_vectors % g ? 1 : 0));
  return groups;
}

void BatchFitness::evaluate(const Request& request) const {
  const int nv = static_cast<int>((request.candidates.size() + kLanes - 1) / kLanes);
  evaluate_grouped(request, plan_groups(nv, request.threads));
}

std::vector<double> BatchFitness::fitness(std::span<const SensorErrors> candidates,
                                          FitnessKind kind, int threads,
                                          std::string_view cpu_path) const {
  std::vector<double> f(candidates.size());
  Request request;
  request.candidates = candidates;
  request.fitness = f;
  request.kind = kind;
  request.threads = threads;
  request.cpu_path = cpu_path;
  evaluate(request);
  return f;
}

void BatchFitness::evaluate_grouped(const Request& request, const std::vector<int>& groups) const {
  if (!supported())
    throw std::invalid_argument("batched fitness kernel: data not supported (" + reason_ + ")");
  const std::size_t K = request.candidates.size();
  if (request.fitness.size() != K)
    throw std::invalid_argument("batched fitness: " + std::to_string(K) + " candidates but " +
                                std::to_string(request.fitness.size()) + " fitness slots");
  if (!request.residuals.empty() && request.residuals.size() != K)
    throw std::invalid_argument("batched fitness: residual slots do not match the candidates");
  if (!request.errors.empty() && request.errors.size() != K)
    throw std::invalid_argument("batched fitness: error slots do not match the candidates");
  int total = 0;
  for (int g : groups) {
    if (g < 1 || g > kMaxChains) throw std::invalid_argument("batched fitness: bad group size");
    total += g;
  }
  if (static_cast<std::size_t>(total) * kLanes < K ||
      static_cast<std::size_t>(total - (groups.empty() ? 0 : 1)) * kLanes >= K + kLanes)
    throw std::invalid_argument("batched fitness: groups do not cover the candidates");
  if (K == 0) return;

  const NavigationProblem& nav = *problem_;
  const Impl& im = *impl_;
  const batch_kernel::KernelPath& kernel =
      request.cpu_path.empty() ? cpu_path() : cpu_path_named(request.cpu_path);
  const bool sum_squares = request.kind == FitnessKind::kSumSquares;
  std::vector<std::exception_ptr> errors(K);
  std::vector<std::size_t> first(groups.size());
  for (std::size_t g = 1; g < groups.size(); ++g)
    first[g] = first[g - 1] + static_cast<std::size_t>(groups[g - 1]) * kLanes;
  // The residual vectors are allocated here, on the calling thread, advised for huge pages
  // (a long flight's vector is megabytes), and zeroed by the groups' threads below. Allocated
  // in the groups' loop instead, they made `insid identify --algo lm` 1.5x slower
  // (results/perf/README.md, "Residual requests").
  if (!request.residuals.empty())
    for (std::vector<double>& r : request.residuals) reserve_huge_pages(r, 2 * im.n_epochs);

  const int n_groups = static_cast<int>(groups.size());
  const int threads = std::max(1, std::min(request.threads, n_groups));
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1)
  for (int g = 0; g < n_groups; ++g) {
    const int nvec = groups[static_cast<std::size_t>(g)];
    const int L = nvec * kLanes;
    const std::size_t i0 = first[static_cast<std::size_t>(g)];
    std::vector<LaneInit> inits(static_cast<std::size_t>(L));
    std::vector<bool> ok(static_cast<std::size_t>(L), false);
    std::map<double, EventList> latency_events;
    std::map<double, StartList> latency_starts;
    int valid = -1;
    bool general = false, lever = false;
    // The group's residual vectors, zeroed by the thread that fills them (zeros stay for a
    // candidate whose set-up fails): a long flight's vector is megabytes, and its first touch
    // was most of a residual request while it ran serially before the groups
    // (BM_FitnessBatchedResiduals).
    if (!request.residuals.empty())
      for (std::size_t i = i0; i < std::min(K, i0 + static_cast<std::size_t>(L)); ++i)
        request.residuals[i].assign(2 * im.n_epochs, 0.0);
    for (int l = 0; l < L; ++l) {
      const std::size_t i = i0 + static_cast<std::size_t>(l);
      if (i >= K) break;
      const SensorErrors& c = request.candidates[i];
      try {
        const EventList* events = &im.events0;
        const StartList* starts = &im.starts0;
        if (c.gnss_latency_s != 0.0) {
          auto it = latency_events.find(c.gnss_latency_s);
          if (it == latency_events.end())
            it = latency_events.emplace(c.gnss_latency_s, make_events(nav, c.gnss_latency_s)).first;
          events = &it->second;
          auto is = latency_starts.find(c.gnss_latency_s);
          if (is == latency_starts.end())
            is = latency_starts.emplace(c.gnss_latency_s, make_starts(nav, c.gnss_latency_s)).first;
          starts = &is->second;
        }
        setup_lane(nav, c, events, starts, sum_squares,
                   request.residuals.empty() ? nullptr : &request.residuals[i],
                   inits[static_cast<std::size_t>(l)]);
        ok[static_cast<std::size_t>(l)] = true;
        if (valid < 0) valid = l;
        general = general || inits[static_cast<std::size_t>(l)].general;
        lever = lever || inits[static_cast<std::size_t>(l)].lever;
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
    std::vector<double> acc(static_cast<std::size_t>(L), 0.0);
    if (valid >= 0) {
      // Padding and failed lanes run a copy of a valid lane, without residual output.
      std::vector<LaneInit*> ptrs(static_cast<std::size_t>(L));
      for (int l = 0; l < L; ++l) {
        if (!ok[static_cast<std::size_t>(l)]) {
          inits[static_cast<std::size_t>(l)] = inits[static_cast<std::size_t>(valid)];
          inits[static_cast<std::size_t>(l)].residuals = nullptr;
        }
        ptrs[static_cast<std::size_t>(l)] = &inits[static_cast<std::size_t>(l)];
      }
      kernel.pick(nvec, general, lever)(nav, im, ptrs.data(), sum_squares, acc.data());
    }
    for (int l = 0; l < L; ++l) {
      const std::size_t i = i0 + static_cast<std::size_t>(l);
      if (i >= K) break;
      request.fitness[i] = ok[static_cast<std::size_t>(l)]
                               ? acc[static_cast<std::size_t>(l)]
                               : std::numeric_limits<double>::quiet_NaN();
    }
  }

  for (std::size_t i = 0; i < K; ++i) {
    if (!errors[i]) continue;
    if (!request.errors.empty()) {
      request.errors[i] = errors[i];
    } else {
      std::rethrow_exception(errors[i]);
    }
  }
}

}  // namespace insid
