#include "locd/ceiling_pf/ceiling_particle_filter.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "locd/sdk/errors.hpp"
#include "locd/sdk/gaussian.hpp"

namespace locd::ceiling_pf {

namespace {
constexpr size_t kMaxLandmarkPairs = 20'000'000;

double log_sum_exp(const std::vector<double>& values) {
  const double top = *std::max_element(values.begin(), values.end());
  if (!std::isfinite(top)) return top;
  double sum = 0.0;
  for (double v : values) sum += std::exp(v - top);
  return top + std::log(sum);
}
}  // namespace

Detection Detection::from_point(const Eigen::Vector2d& p) {
  return {p, p.norm(), std::atan2(p.y(), p.x())};
}

CeilingParticleFilter::CeilingParticleFilter(const ParticleFilterConfig& config,
                                             std::shared_ptr<const NearestLandmarkIndex> index,
                                             const VelocityMotionModel& motion)
    : config_(config),
      index_(std::move(index)),
      motion_(motion),
      rng_(config.seed),
      kld_{config.kld_sampling, config.particles, config.min_particles, config.max_particles,
           config.kld_epsilon,  config.kld_quantile, config.kld_bin},
      bins_(config.kld_bin),
      recovery_(config.alpha_slow, config.alpha_fast) {
  if (!index_) throw ConfigError("CeilingParticleFilter needs a landmark index");
  if (config_.candidates < 1 || config_.candidates > kMaxCandidates) {
    throw ConfigError("ceiling_pf: candidates = " + std::to_string(config_.candidates) + " is out of range; allowed: [1, " +
                      std::to_string(kMaxCandidates) + "]");
  }
  if (config_.candidates > index_->k()) config_.candidates = index_->k();
  // Two landmarks seen in one frame are at most two view ranges apart.
  max_pair_distance_ = 2.0 * config_.max_range;
  const auto& landmarks = index_->landmarks();
  std::vector<int> by_x(landmarks.size());
  std::iota(by_x.begin(), by_x.end(), 0);
  std::sort(by_x.begin(), by_x.end(), [&](int a, int b) { return landmarks[a].x() < landmarks[b].x(); });
  std::vector<std::pair<double, std::pair<int, int>>> pairs;
  for (size_t a = 0; a < by_x.size(); ++a) {
    for (size_t b = a + 1; b < by_x.size(); ++b) {
      const int i = by_x[a], j = by_x[b];
      if (landmarks[j].x() - landmarks[i].x() > max_pair_distance_) break;
      const double d = (landmarks[j] - landmarks[i]).norm();
      if (d > max_pair_distance_ || d <= 0.0) continue;
      pairs.push_back({d, {i, j}});
      pairs.push_back({d, {j, i}});
      if (pairs.size() > kMaxLandmarkPairs) {
        throw ConfigError("landmark map has more than " + std::to_string(kMaxLandmarkPairs) +
                                    " landmark pairs within view of each other");
      }
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pair_distance_.reserve(pairs.size());
  pairs_.reserve(pairs.size());
  for (const auto& p : pairs) {
    pair_distance_.push_back(p.first);
    pairs_.push_back(p.second);
  }
}

void CeilingParticleFilter::set_pose(const Pose2& mean, const Eigen::Matrix3d& covariance) {
  const GaussianSampler sampler(mean.vector(), covariance);
  particles_.assign(config_.particles, Particle{});
  const double w = 1.0 / static_cast<double>(particles_.size());
  for (Particle& p : particles_) {
    const Eigen::Vector3d s = sampler.sample(rng_);
    p.pose = Pose2(s.x(), s.y(), normalize_angle(s.z()));
    p.weight = w;
  }
  mode_ = mean;
  recovery_.reset();
  just_injected_.clear();
  localized_ = true;
}

void CeilingParticleFilter::set_unknown() {
  particles_.clear();
  localized_ = false;
  mode_.reset();
  recovery_.reset();
}

void CeilingParticleFilter::set_particles(std::vector<Particle> particles) {
  particles_ = std::move(particles);
  just_injected_.clear();
  normalize_weights(particles_);
  mode_.reset();
}

void CeilingParticleFilter::predict(const VelocityCommand& u) {
  if (particles_.empty() || !(u.dt > 0.0)) return;
  for (Particle& p : particles_) p.pose = motion_.sample(p.pose, u, rng_);
  if (mode_) mode_ = VelocityMotionModel::move(*mode_, u.linear, u.angular, 0.0, u.dt);
}

double CeilingParticleFilter::log_likelihood(const Pose2& pose, const std::vector<Detection>& detections,
                                             std::vector<Association>* associations, double* explained) const {
  if (explained) *explained = 0.0;
  const auto& landmarks = index_->landmarks();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double sr = config_.range_stddev;
  const double outlier = (1.0 - config_.hit_fraction) / (config_.max_range * 2.0 * M_PI);
  LandmarkCandidates candidates;
  double total = 0.0;
  if (associations) associations->assign(detections.size(), Association{});
  for (size_t k = 0; k < detections.size(); ++k) {
    const Detection& d = detections[k];
    // Bearing is ill-defined right above the camera: widen it by the range noise over range.
    const double sb = std::sqrt(config_.bearing_stddev * config_.bearing_stddev +
                                (sr * sr) / std::max(d.range * d.range, 1e-4));
    const Eigen::Vector2d in_map(pose.x + c * d.point.x() - s * d.point.y(),
                                 pose.y + s * d.point.x() + c * d.point.y());
    const int n = config_.scan_all_landmarks ? index_->nearest_brute_force(in_map, candidates)
                                              : index_->nearest(in_map, candidates);
    double best = std::numeric_limits<double>::infinity();
    int best_id = -1;
    for (int i = 0; i < n && i < config_.candidates; ++i) {
      // Predicted range and bearing of landmark i from the particle (eq. 8-9's z*).
      const double dx = landmarks[candidates[i]].x() - pose.x, dy = landmarks[candidates[i]].y() - pose.y;
      const double lx = c * dx + s * dy, ly = -s * dx + c * dy;
      const double er = (d.range - std::sqrt(lx * lx + ly * ly)) / sr;
      const double eb = normalize_angle(d.bearing - std::atan2(ly, lx)) / sb;
      const double e2 = er * er + eb * eb;
      if (e2 < best) {
        best = e2;
        best_id = candidates[i];
      }
    }
    // Eq. 8-9 divided by their peak (a factor shared by all particles for this detection, so
    // the weights are unchanged): 1 is a perfect fit whatever the detection's range.
    const double peak = config_.hit_fraction / (2.0 * M_PI * sr * sb);
    const double hit = peak * std::exp(-0.5 * best);
    const double fit = (hit + outlier) / (peak + outlier);
    total += std::log(fit);
    if (explained) *explained += fit / static_cast<double>(detections.size());
    if (associations) {
      (*associations)[k] = {hit > outlier ? best_id : -1, best, std::min(n, config_.candidates)};
    }
  }
  return total;
}

CorrectionReport CeilingParticleFilter::correct(const std::vector<Detection>& detections) {
  CorrectionReport report;
  report.detections = detections.size();
  if (detections.empty()) return report;
  if (particles_.empty()) {
    const size_t count = config_.kld_sampling ? config_.global_particles : config_.particles;
    const std::vector<Pose2> poses = sample_from_detections(detections, count);
    particles_.clear();
    for (const Pose2& p : poses) particles_.push_back({p, 1.0 / static_cast<double>(poses.size())});
    report.global_start = true;
    recovery_.reset();
    just_injected_.clear();
  }
  const size_t n = particles_.size();
  std::vector<double> log_w(n);
  // For augmented MCL: the prior-weighted mean share of detections a particle explains (fit
  // in [0, 1] per detection), over the particles not just injected: counting those would lower
  // the average by the share injected and so keep injecting (a self-sustaining loop).
  double explained_sum = 0.0, settled_prior = 0.0;
  for (size_t m = 0; m < n; ++m) {
    double explained = 0.0;
    const double ll = log_likelihood(particles_[m].pose, detections, nullptr, &explained);
    log_w[m] = std::log(std::max(particles_[m].weight, 1e-300)) + ll;
    if (m < just_injected_.size() && just_injected_[m]) continue;
    explained_sum += particles_[m].weight * explained;
    settled_prior += particles_[m].weight;
  }
  const double log_marginal = log_sum_exp(log_w);
  report.mean_likelihood = settled_prior > 0.0 ? explained_sum / settled_prior : 0.0;
  recovery_.update(report.mean_likelihood);
  for (size_t m = 0; m < n; ++m) particles_[m].weight = std::exp(log_w[m] - log_marginal);
  normalize_weights(particles_);
  report.effective_sample_size = effective_sample_size(particles_);

  const size_t best = static_cast<size_t>(
      std::max_element(particles_.begin(), particles_.end(),
                       [](const Particle& a, const Particle& b) { return a.weight < b.weight; }) -
      particles_.begin());
  log_likelihood(particles_[best].pose, detections, &report.associations);
  // The mode: the heavier of the clusters around the previous mode and around the best particle.
  const FilterEstimate around_best = main_cluster(particles_, config_.cluster_radius, mode_);
  mode_ = around_best.pose;

  // Table 8.3's max(0, 1 - w_fast / w_slow), only once the short-term average has fallen well
  // below the long-term one: the fit of a well-localized set also swings with the geometry (one
  // landmark near the image centre, turns), and with a single landmark in view every injected
  // particle fits as well as the true ones, so small injections would erode the true cluster.
  report.injection_probability = config_.recovery ? recovery_.injection_probability(config_.min_injection_probability) : 0.0;
  // Until one hypothesis holds half the weight after a global start or a kidnapping, keep
  // drawing some particles from the detections: a frame with two landmarks in view fixes the
  // pose, and the hypotheses the first frames gave may all be wrong. A localized filter whose
  // cluster thins out for a moment does not do this (the injected particles would keep the
  // cluster's share low and so keep injecting).
  if (report.global_start || report.injection_probability > 0.0) localized_ = false;
  if (around_best.mass >= 0.5) localized_ = true;
  if (config_.recovery && !localized_) {
    report.injection_probability = std::max(report.injection_probability, config_.ambiguous_injection);
  }
  const bool degenerate = report.effective_sample_size < config_.resample_ess_fraction * static_cast<double>(n);
  if (degenerate || report.injection_probability > 0.0) {
    resample(detections, report);
  }
  return report;
}

void CeilingParticleFilter::resample(const std::vector<Detection>& detections, CorrectionReport& report) {
  // KLD: the set grows until it is large enough for the bins it occupies, injected particles
  // included (a spread of injected particles asks for more).
  report.injected = kld_resample(
      particles_, kld_, report.injection_probability,
      [&](size_t count, std::vector<Particle>& out) {
        for (const Pose2& p : sample_from_detections(detections, count)) out.push_back({p, 0.0});
      },
      bins_, rng_);
  just_injected_.assign(particles_.size(), false);
  std::fill(just_injected_.end() - static_cast<std::ptrdiff_t>(report.injected), just_injected_.end(), true);
  report.resampled = true;
}

std::vector<Pose2> CeilingParticleFilter::sample_from_detections(const std::vector<Detection>& detections,
                                                                 size_t count) {
  std::vector<Pose2> poses;
  poses.reserve(count);
  if (detections.empty()) return poses;
  const auto& landmarks = index_->landmarks();
  std::normal_distribution<double> position_noise(0.0, config_.proposal_position_stddev);
  std::normal_distribution<double> heading_noise(0.0, config_.proposal_heading_stddev);
  std::uniform_real_distribution<double> heading(-M_PI, M_PI);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<size_t> pick_detection(0, detections.size() - 1);
  std::uniform_int_distribution<size_t> pick_landmark(0, landmarks.size() - 1);
  for (size_t s = 0; s < count; ++s) {
    const Detection& a = detections[pick_detection(rng_)];
    Pose2 pose;
    bool from_pair = false;
    if (detections.size() >= 2 && !pairs_.empty() && unit(rng_) < 0.8) {
      // Two detections fix the pose once their landmarks are known: pick a mapped pair of the
      // same distance (either order) and align.
      const Detection* b = &detections[pick_detection(rng_)];
      while (b == &a) b = &detections[pick_detection(rng_)];
      const double d = (b->point - a.point).norm();
      const auto lo = std::lower_bound(pair_distance_.begin(), pair_distance_.end(), d - config_.pair_distance_tolerance);
      const auto hi = std::upper_bound(lo, pair_distance_.end(), d + config_.pair_distance_tolerance);
      if (hi > lo) {
        const size_t k = static_cast<size_t>(lo - pair_distance_.begin()) +
                         std::uniform_int_distribution<size_t>(0, static_cast<size_t>(hi - lo) - 1)(rng_);
        const Eigen::Vector2d& li = landmarks[pairs_[k].first];
        const Eigen::Vector2d& lj = landmarks[pairs_[k].second];
        const Eigen::Vector2d map_dir = lj - li, body_dir = b->point - a.point;
        pose.theta = std::atan2(map_dir.y(), map_dir.x()) - std::atan2(body_dir.y(), body_dir.x());
        const Eigen::Vector2d offset = Eigen::Rotation2Dd(pose.theta) * a.point;
        pose.x = li.x() - offset.x();
        pose.y = li.y() - offset.y();
        from_pair = true;
      }
    }
    if (!from_pair) {
      const Eigen::Vector2d& l = landmarks[pick_landmark(rng_)];
      pose.theta = heading(rng_);
      const Eigen::Vector2d offset = Eigen::Rotation2Dd(pose.theta) * a.point;
      pose.x = l.x() - offset.x();
      pose.y = l.y() - offset.y();
    }
    pose.x += position_noise(rng_);
    pose.y += position_noise(rng_);
    pose.theta = normalize_angle(pose.theta + heading_noise(rng_));
    poses.push_back(pose);
  }
  return poses;
}

std::optional<FilterEstimate> CeilingParticleFilter::estimate() const {
  if (particles_.empty()) return std::nullopt;
  if (mode_) {
    FilterEstimate e = cluster_around(particles_, *mode_, config_.cluster_radius);
    if (e.mass > 0.0) return e;
  }
  const auto best = std::max_element(particles_.begin(), particles_.end(),
                                     [](const Particle& a, const Particle& b) { return a.weight < b.weight; });
  return cluster_around(particles_, best->pose, config_.cluster_radius);
}

}  // namespace locd::ceiling_pf
