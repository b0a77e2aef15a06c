#include "locd/grid_mcl/grid_particle_filter.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <functional>
#include <limits>
#include <mutex>
#include <thread>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/gaussian.hpp"

namespace locd::grid_mcl {

// Worker threads for the weighting (option `threads`): the caller and threads - 1 workers take
// chunks of the particle set until none is left.
class WeightingPool {
 public:
  explicit WeightingPool(int threads) {
    for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { loop(); });
  }
  ~WeightingPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    start_.notify_all();
    for (std::thread& t : workers_) t.join();
  }
  size_t threads() const { return workers_.size() + 1; }

  void run(size_t chunks, const std::function<void(size_t)>& work) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      work_ = &work;
      chunks_ = chunks;
      next_ = 0;
      busy_ = static_cast<int>(workers_.size());
      ++generation_;
    }
    start_.notify_all();
    take(work, chunks);
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return busy_ == 0; });
    work_ = nullptr;
  }

 private:
  void take(const std::function<void(size_t)>& work, size_t chunks) {
    for (size_t c = next_++; c < chunks; c = next_++) work(c);
  }
  void loop() {
    size_t seen = 0;
    for (;;) {
      const std::function<void(size_t)>* work = nullptr;
      size_t chunks = 0;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        start_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        work = work_;
        chunks = chunks_;
      }
      take(*work, chunks);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--busy_ == 0) done_.notify_one();
    }
  }

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  const std::function<void(size_t)>* work_ = nullptr;
  size_t chunks_ = 0;
  std::atomic<size_t> next_{0};
  size_t generation_ = 0;
  int busy_ = 0;
  bool stop_ = false;
};

namespace {

bool recovery_enabled(const FilterConfig& c) { return c.recovery_alpha_slow > 0.0 && c.recovery_alpha_fast > 0.0; }

std::string percent(double share, int decimals = 0) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*f %%", decimals, 100.0 * share);
  return text;
}

std::string metres(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", value);
  return text;
}

}  // namespace

GridParticleFilter::GridParticleFilter(const Config& config, std::shared_ptr<const SharedMap> map)
    : config_(config),
      map_(std::move(map)),
      motion_(config.motion_model, config.motion),
      laser_(map_, config.laser),
      rng_(config.filter.seed),
      kld_{true, config.filter.max_particles, config.filter.min_particles, config.filter.max_particles,
           config.filter.pf_err, config.filter.pf_z, config.filter.kld_bin},
      bins_(config.filter.kld_bin),
      recovery_(config.filter.recovery_alpha_slow, config.filter.recovery_alpha_fast) {
  if (map_->map.free_cells() == 0) {
    throw ConfigError("map '" + map_->yaml.yaml_file.filename().string() + "' has no free cell to localize in");
  }
  if (config_.filter.threads > 1) pool_ = std::make_unique<WeightingPool>(config_.filter.threads);
}

GridParticleFilter::~GridParticleFilter() = default;

void GridParticleFilter::sample_free_poses(size_t count, std::vector<PoseParticle>& out) {
  const GridGeometry& g = map_->map.geometry();
  std::uniform_int_distribution<size_t> cell(0, g.size() - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0), heading(-M_PI, M_PI);
  const std::vector<int8_t>& cells = map_->map.cells();
  for (size_t i = 0; i < count; ++i) {
    size_t c = cell(rng_);
    while (cells[c] != OccupancyMap::kFree) c = cell(rng_);  // the map has free cells (constructor)
    const int row = static_cast<int>(c / static_cast<size_t>(g.width)), col = static_cast<int>(c % static_cast<size_t>(g.width));
    const Eigen::Vector2d corner = g.origin + g.resolution * Eigen::Vector2d(col, row);
    out.push_back({Pose2(corner.x() + unit(rng_) * g.resolution, corner.y() + unit(rng_) * g.resolution, heading(rng_)), 1.0});
  }
}

void GridParticleFilter::set_pose(const Pose2& mean, const Eigen::Matrix3d& covariance) {
  const GaussianSampler sampler(mean.vector(), covariance);
  particles_.assign(config_.filter.max_particles, PoseParticle{});
  for (PoseParticle& p : particles_) {
    const Eigen::Vector3d s = sampler.sample(rng_);
    p = {Pose2(s.x(), s.y(), normalize_angle(s.z())), 1.0};
  }
  normalize_weights(particles_);
  recovery_.reset();
  odometry_at_update_.reset();
  updates_since_resampling_ = 0;
  lost_updates_ = 0;
  uncertain_updates_ = 0;
  hypotheses_.clear();
  ParticleCluster start;
  start.pose = mean;
  start.covariance = covariance;
  start.mass = 1.0;
  estimate_ = start;
  assessment_ = {LocalizationState::kUncertain, "initial pose given, no scan matched yet"};
}

void GridParticleFilter::set_global() {
  lost_updates_ = 0;
  uncertain_updates_ = 0;
  hypotheses_.clear();
  particles_.clear();
  particles_.reserve(config_.filter.global_particles);
  sample_free_poses(config_.filter.global_particles, particles_);
  normalize_weights(particles_);
  recovery_.reset();
  odometry_at_update_.reset();
  updates_since_resampling_ = 0;
  // The best estimate there is (a wide, light cluster), published with its covariance while lost.
  estimate_ = main_cluster(particles_, config_.filter.cluster_radius, std::nullopt);
  assessment_ = {LocalizationState::kLost, "global localization: particles spread over the free space"};
}

CorrectionReport GridParticleFilter::correct(const LaserScan& scan, const Pose2& odometry) {
  CorrectionReport report;
  if (particles_.empty()) return report;
  if (odometry_at_update_) {
    const Pose2& last = *odometry_at_update_;
    const bool moved = std::abs(odometry.x - last.x) > config_.filter.update_min_d ||
                       std::abs(odometry.y - last.y) > config_.filter.update_min_d ||
                       std::abs(normalize_angle(odometry.theta - last.theta)) > config_.filter.update_min_a;
    if (!moved) return report;
    motion_.sample(particles_, last, odometry, rng_);
    if (estimate_) estimate_->pose = estimate_->pose * (last.inverse() * odometry);
    for (Hypothesis& h : hypotheses_) h.pose = h.pose * (last.inverse() * odometry);
  }
  odometry_at_update_ = odometry;
  report.updated = true;
  const PreparedScan prepared = prepare_scan(scan, config_.laser);
  weigh(prepared, report);
  // The estimate: the main cluster (the heavier of the clusters around the previous mode and the
  // heaviest particle), once when the heaviest particle lies in the previous mode's cluster.
  const double radius = config_.filter.cluster_radius;
  const auto best = std::max_element(particles_.begin(), particles_.end(),
                                     [](const PoseParticle& a, const PoseParticle& b) { return a.weight < b.weight; });
  if (estimate_ && std::hypot(best->pose.x - estimate_->pose.x, best->pose.y - estimate_->pose.y) < 0.5 * radius) {
    estimate_ = cluster_around(particles_, estimate_->pose, radius);
  } else {
    estimate_ = main_cluster(particles_, radius, estimate_ ? std::optional<Pose2>(estimate_->pose) : std::nullopt);
  }
  // The beams the see-through check casts (see_through_beams), prepared once per update.
  PreparedScan dense;
  if (config_.state.tracking_max_see_through < 1.0) {
    LaserModelConfig beams = config_.laser;
    beams.max_beams = config_.state.see_through_beams;
    dense = prepare_scan(scan, beams);
  }
  assess(prepared, dense, report);
  // Kidnapped, or a search settled on the wrong place: the filter holds one pose (its main
  // cluster has tracking_min_cluster_mass) but the scan has not fitted it (fit below
  // tracking_min_fit) for relocalize_after_lost_updates updates in a row: global localization.
  // Evidence a well-tracking filter did not give on the real logs (issue 21, bench/realdata with
  // the shipped config, seed 1: within 0.5 m of the reference the fit stayed below 50 % for at most
  // 5 updates in a row on intel, never on freiburg-079). Returns through the map's walls never
  // count: a real map lacks open doors, glass and half-seen walls, and a well-tracking filter sees
  // through them for many updates; they make the state uncertain only.
  const StateCriteria& c = config_.state;
  const bool committed = estimate_->mass >= c.tracking_min_cluster_mass;
  lost_updates_ = committed && report.misfit ? lost_updates_ + 1 : 0;
  const int patience = config_.filter.relocalize_after_lost_updates;
  if (patience > 0 && lost_updates_ >= patience) {
    const std::string reason = assessment_.reason;
    set_global();
    assessment_.reason = reason + " for " + std::to_string(patience) + " updates: global relocalization";
    report.relocalized = true;
    return report;
  }
  if (const std::optional<Pose2> moved = follow_hypotheses(prepared, dense, report)) {
    const double away = std::hypot(moved->x - estimate_->pose.x, moved->y - estimate_->pose.y);
    const std::string reason = assessment_.reason + "; a pose " + metres(away) + " m away passed the fit and " +
                               "see-through tests for " + std::to_string(config_.filter.hypothesis_confirm_updates) +
                               " updates: relocalization there";
    const Eigen::Vector3d stddev = config_.initial_stddev;
    set_pose(*moved, stddev.cwiseProduct(stddev).asDiagonal());
    assessment_ = {LocalizationState::kLost, reason};
    report.relocalized = true;
    return report;
  }
  const bool degenerate = report.effective_sample_size < 0.5 * static_cast<double>(particles_.size());
  if (++updates_since_resampling_ >= config_.filter.resample_interval && (!config_.filter.selective_resampling || degenerate)) {
    updates_since_resampling_ = 0;
    report.injection_probability = recovery_enabled(config_.filter) ? recovery_.injection_probability() : 0.0;
    report.injected = kld_resample(
        particles_, kld_, report.injection_probability,
        [this](size_t count, std::vector<PoseParticle>& out) { sample_free_poses(count, out); }, bins_, rng_);
    report.resampled = true;
  }
  return report;
}

void GridParticleFilter::weigh(const PreparedScan& scan, CorrectionReport& report) {
  // Searching (with search_sigma_hit set): AMCL's robust likelihood_field with a wider field, so
  // several hypotheses live on and particles near the truth are pulled in: while lost
  // search_sigma_hit, while uncertain with the set still spread (its main cluster below
  // tracking_min_cluster_mass or wider than tracking_max_position_stddev) sqrt(sigma_hit x that).
  // Not while uncertain with the set on one pose: on real logs a filter that tracks well is
  // uncertain for half its updates (returns through open doors and glass, clutter the map
  // lacks), and a wider field then let the set drift onto rivals 9-20 m away (issue 21).
  const LaserModelConfig& l = config_.laser;
  const StateCriteria& c = config_.state;
  bool spread = !estimate_ || estimate_->mass < c.tracking_min_cluster_mass;
  if (!spread) {
    const double variance =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(estimate_->covariance.topLeftCorner<2, 2>()).eigenvalues()(1);
    spread = variance > c.tracking_max_position_stddev * c.tracking_max_position_stddev;
  }
  const bool lost = assessment_.state == LocalizationState::kLost;
  const bool search = l.search_sigma_hit > l.sigma_hit && (lost || (assessment_.state == LocalizationState::kUncertain && spread));
  double sigma = l.sigma_hit;
  if (search) sigma = lost ? l.search_sigma_hit : std::sqrt(l.sigma_hit * l.search_sigma_hit);
  report.sigma_hit = sigma;
  laser_.set_search(search, sigma);
  laser_.prepare(scan);
  report.beams = scan.hits();
  const size_t n = particles_.size();
  if (factors_.capacity() > 4 * n + 4096) {  // the set shrank (a global start is over): give memory back
    std::vector<double>().swap(factors_);
    std::vector<double>().swap(measures_);
  }
  factors_.resize(n);
  measures_.resize(n);
  constexpr size_t kChunk = 2048;
  if (pool_ && n > kChunk) {
    const size_t chunks = (n + kChunk - 1) / kChunk;
    pool_->run(chunks, [&](size_t c) {
      const size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
      laser_.factors(particles_, begin, end, scan, factors_.data() + begin, measures_.data() + begin);
    });
  } else {
    laser_.factors(particles_, 0, n, scan, factors_.data(), measures_.data());
  }
  // The recovery's average: the prior-weighted mean pz per beam (Table 8.3's w_avg, measured the
  // same way whatever the model).
  double average = 0.0;
  for (size_t m = 0; m < n; ++m) average += particles_[m].weight * measures_[m];
  if (laser_.log_domain()) {
    // w_i exp(f_i), normalised through the largest log weight.
    double top = -std::numeric_limits<double>::infinity();
    for (size_t m = 0; m < n; ++m) {
      factors_[m] += std::log(std::max(particles_[m].weight, 1e-300));
      top = std::max(top, factors_[m]);
    }
    for (size_t m = 0; m < n; ++m) particles_[m].weight = std::exp(factors_[m] - top);
  } else {
    for (size_t m = 0; m < n; ++m) particles_[m].weight *= factors_[m];
  }
  normalize_weights(particles_);
  report.average_likelihood = average;
  report.effective_sample_size = effective_sample_size(particles_);
  if (report.beams > 0) recovery_.update(average);
}

void GridParticleFilter::assess(const PreparedScan& scan, const PreparedScan& dense, CorrectionReport& report) {
  const StateCriteria& c = config_.state;
  const ParticleCluster& e = *estimate_;
  // Hits ending where the map knows nothing (the part of a building it lacks) are not counted.
  report.fit = laser_.fit(e.pose, scan, c.fit_distance, true, &report.known);
  // Only where the map can judge the scan: in a part of the building it lacks, odometry carries.
  report.misfit = report.fit < c.tracking_min_fit && report.known >= c.tracking_min_known;
  if (c.tracking_max_see_through < 1.0) {
    report.see_through = laser_.see_through(e.pose, dense, c.see_through_margin, c.see_through_fraction);
  }
  const double position_stddev =
      std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(e.covariance.topLeftCorner<2, 2>()).eigenvalues()(1)));
  const double yaw_stddev = std::sqrt(std::max(0.0, e.covariance(2, 2)));
  const double ratio = recovery_.slow() > 0.0 ? recovery_.fast() / recovery_.slow() : 1.0;
  const std::string fit_text = "scan fit " + percent(report.fit) + " (beams ending within " + metres(c.fit_distance) +
                               " m of an obstacle)";
  const std::string mass_text = "main cluster " + percent(e.mass) + " of the weight";
  if (report.beams == 0) {
    assessment_ = {LocalizationState::kUncertain, "no beam of the scan hit anything within range"};
  } else if (e.mass < c.lost_max_cluster_mass) {
    assessment_ = {LocalizationState::kLost, mass_text + " < " + percent(c.lost_max_cluster_mass)};
  } else if (report.known < c.tracking_min_known) {  // the fit is too thin to say lost
    assessment_ = {LocalizationState::kUncertain, "the map knows where " + percent(report.known) +
                                                      " of the scan's returns end < " + percent(c.tracking_min_known)};
  } else if (report.fit < c.lost_max_fit) {
    assessment_ = {LocalizationState::kLost, fit_text + " < " + percent(c.lost_max_fit)};
  } else if (report.fit < c.tracking_min_fit) {
    assessment_ = {LocalizationState::kUncertain, fit_text + " < " + percent(c.tracking_min_fit)};
  } else if (report.see_through > c.tracking_max_see_through) {
    assessment_ = {LocalizationState::kUncertain, percent(report.see_through, 1) +
                                                      " of the returns pass through the map's walls (by more than " +
                                                      metres(c.see_through_margin) + " m + " +
                                                      percent(c.see_through_fraction) + " of their range) > " +
                                                      percent(c.tracking_max_see_through, 1)};
  } else if (e.mass < c.tracking_min_cluster_mass) {
    assessment_ = {LocalizationState::kUncertain, mass_text + " < " + percent(c.tracking_min_cluster_mass)};
  } else if (position_stddev > c.tracking_max_position_stddev) {
    assessment_ = {LocalizationState::kUncertain, "position stddev " + metres(position_stddev) + " m > " +
                                                      metres(c.tracking_max_position_stddev) + " m"};
  } else if (yaw_stddev > c.tracking_max_yaw_stddev) {
    assessment_ = {LocalizationState::kUncertain,
                   "yaw stddev " + metres(yaw_stddev) + " rad > " + metres(c.tracking_max_yaw_stddev) + " rad"};
  } else if (recovery_enabled(config_.filter) && ratio < c.tracking_min_fast_slow_ratio) {
    assessment_ = {LocalizationState::kUncertain,
                   "w_fast / w_slow " + metres(ratio) + " < " + metres(c.tracking_min_fast_slow_ratio) + " (recovering)"};
  } else {
    assessment_ = {LocalizationState::kTracking, fit_text + ", " + mass_text + ", position stddev " +
                                                     metres(position_stddev) + " m"};
  }
}

std::optional<Pose2> GridParticleFilter::follow_hypotheses(const PreparedScan& scan, const PreparedScan& dense,
                                                          const CorrectionReport& report) {
  const FilterConfig& f = config_.filter;
  const StateCriteria& c = config_.state;
  if (f.hypothesis_test_after_uncertain_updates <= 0) return std::nullopt;
  uncertain_updates_ = assessment_.state == LocalizationState::kTracking ? std::max(0, uncertain_updates_ - 1)
                                                                          : uncertain_updates_ + 1;
  const bool committed = estimate_->mass >= c.tracking_min_cluster_mass;
  const bool fails = report.misfit || report.see_through > c.tracking_max_see_through;
  if (!committed || !fails || report.beams == 0) {
    hypotheses_.clear();
    return std::nullopt;
  }
  // Two hypotheses are one when they agree in position (cluster_radius) and heading.
  const auto distinct = [&](const Pose2& pose) {
    for (const Hypothesis& h : hypotheses_) {
      if (std::hypot(pose.x - h.pose.x, pose.y - h.pose.y) < f.cluster_radius &&
          std::abs(normalize_angle(pose.theta - h.pose.theta)) < 0.5) {
        return false;
      }
    }
    return true;
  };
  // Those followed so far, checked on this scan; the older kept where two have become one.
  std::vector<Hypothesis> followed;
  followed.swap(hypotheses_);
  for (const Hypothesis& h : followed) {
    const std::optional<Pose2> still = checked(h.pose, scan, dense, report.fit);
    if (still && distinct(*still)) hypotheses_.push_back({*still, h.confirmations + 1});
  }
  if (uncertain_updates_ >= f.hypothesis_test_after_uncertain_updates) {
    uncertain_updates_ = 0;
    // Candidates ranked by their fit; the best few refined, checked and followed.
    std::vector<PoseParticle> candidates;
    candidates.reserve(f.hypothesis_candidates);
    sample_free_poses(f.hypothesis_candidates, candidates);
    for (PoseParticle& p : candidates) p.weight = laser_.fit(p.pose, scan, c.fit_distance);
    const size_t refined = std::min<size_t>(kMaxHypotheses, candidates.size());
    std::partial_sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(refined), candidates.end(),
                      [](const PoseParticle& a, const PoseParticle& b) { return a.weight > b.weight; });
    for (size_t k = 0; k < refined && hypotheses_.size() < kMaxHypotheses; ++k) {
      const std::optional<Pose2> pose = checked(candidates[k].pose, scan, dense, report.fit);
      if (pose && distinct(*pose)) hypotheses_.push_back({*pose, 0});
    }
  }
  // One place only, confirmed: move there. Look-alike places (a symmetric building) wait until
  // the scans tell them apart.
  if (hypotheses_.size() == 1 && hypotheses_.front().confirmations >= f.hypothesis_confirm_updates) {
    const Pose2 pose = hypotheses_.front().pose;
    hypotheses_.clear();
    return pose;
  }
  return std::nullopt;
}

std::optional<Pose2> GridParticleFilter::checked(const Pose2& candidate, const PreparedScan& scan,
                                                 const PreparedScan& dense, double estimate_fit) const {
  const StateCriteria& c = config_.state;
  const Pose2 pose = refine(candidate, scan);
  // Every hit counts towards tracking_min_fit (a place the map hardly knows does not pass); the
  // comparison with the estimate counts the hits in known cells on both sides, as report.fit.
  if (laser_.fit(pose, scan, c.fit_distance) < c.tracking_min_fit ||
      laser_.fit(pose, scan, c.fit_distance, true) < estimate_fit) {
    return std::nullopt;
  }
  if (std::hypot(pose.x - estimate_->pose.x, pose.y - estimate_->pose.y) < config_.filter.cluster_radius) return std::nullopt;
  if (c.tracking_max_see_through < 1.0 &&
      laser_.see_through(pose, dense, c.see_through_margin, c.see_through_fraction) > c.tracking_max_see_through) {
    return std::nullopt;
  }
  return pose;
}

Pose2 GridParticleFilter::refine(const Pose2& pose, const PreparedScan& scan) const {
  // Score: sum over the hits of exp(-d^2 / 2 s^2), d the distance from the beam's end to the
  // nearest obstacle, with s shrinking with the step so a candidate a few decimetres off is pulled in.
  const GridGeometry& g = map_->map.geometry();
  const auto score = [&](const Pose2& p, double s) {
    double sum = 0.0;
    for (size_t k = 0; k < scan.end.size(); ++k) {
      if (!scan.hit[k]) continue;
      int row = 0, col = 0;
      if (!g.index_of(p.transform(scan.end[k]), row, col)) continue;
      const double d = map_->field.distance(row, col);
      sum += std::exp(-d * d / (2.0 * s * s));
    }
    return sum;
  };
  Pose2 best = pose;
  for (double step = 0.4; step > 0.04; step *= 0.5) {
    const double s = std::max(config_.laser.sigma_hit, step), turn = 0.5 * step;
    double best_score = score(best, s);
    for (int iteration = 0; iteration < 20; ++iteration) {
      const Pose2 around[] = {Pose2(best.x + step, best.y, best.theta), Pose2(best.x - step, best.y, best.theta),
                              Pose2(best.x, best.y + step, best.theta), Pose2(best.x, best.y - step, best.theta),
                              Pose2(best.x, best.y, normalize_angle(best.theta + turn)),
                              Pose2(best.x, best.y, normalize_angle(best.theta - turn))};
      const Pose2* next = nullptr;
      for (const Pose2& p : around) {
        const double v = score(p, s);
        if (v > best_score) {
          best_score = v;
          next = &p;
        }
      }
      if (!next) break;
      best = *next;
    }
  }
  return best;
}

std::optional<ParticleCluster> GridParticleFilter::estimate() const { return estimate_; }

std::optional<ParticleCluster> GridParticleFilter::estimate_at(const Pose2& odometry) const {
  if (!estimate_) return std::nullopt;
  ParticleCluster e = *estimate_;
  if (odometry_at_update_) e.pose = e.pose * (odometry_at_update_->inverse() * odometry);
  return e;
}

size_t GridParticleFilter::memory_bytes() const {
  return sizeof(*this) + particles_.capacity() * sizeof(PoseParticle) + bins_.memory_bytes() +
         (factors_.capacity() + measures_.capacity()) * sizeof(double) + 2 *
         laser_.table_size() * sizeof(float);
}

}  // namespace locd::grid_mcl
