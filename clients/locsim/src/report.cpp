#include "locd/sim/report.hpp"

#include "locd/sim/evaluation_report.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace locd::sim {

nlohmann::ordered_json localization_json(const StateSummary& l, const std::optional<SimulatedEvent>& event) {
  nlohmann::ordered_json json = state_json(l);
  if (event) {
    json["event"] = event->kind;
    json["event_distance_m"] = event->distance_m;
  }
  return json;
}

// One JSON object on one line (nlohmann-json; a non-finite number is written as null).
void write_json(std::ostream& out, const RunResult& r) {
  const EvaluationSummary& s = r.summary;
  const auto optional = [](const std::optional<double>& v) {
    return v ? nlohmann::ordered_json(*v) : nlohmann::ordered_json(nullptr);
  };
  nlohmann::ordered_json json = {
      {"plugin", r.plugin},
      {"scenario", r.scenario},
      {"robot", r.robot_id},
      {"seed", r.seed},
      {"duration_s", r.duration_s},
      {"measurements", r.measurements},
      {"rejected", r.rejected},
      {"updates", s.updates},
      {"mean_error_m", s.mean_error_m},
      {"rmse_m", s.rmse_m},
      {"p95_error_m", s.p95_error_m},
      {"max_error_m", s.max_error_m},
      {"final_error_m", s.final_error_m},
      {"mean_heading_error_deg", s.mean_heading_error_deg},
      {"update_ms_p50", s.update_ms_p50},
      {"update_ms_p99", s.update_ms_p99},
      {"converged", s.converged},
      {"convergence_time_s", optional(s.convergence_time_s)},
  };
  json["consistency"] = consistency_json(s.consistency);
  json["localization"] = localization_json(s.localization, r.event);
  if (s.latency_ms_p50) {
    json["latency_ms_p50"] = optional(s.latency_ms_p50);
    json["latency_ms_p99"] = optional(s.latency_ms_p99);
    json["overhead_ms_p50"] = optional(s.overhead_ms_p50);
    json["overhead_ms_p99"] = optional(s.overhead_ms_p99);
    json["max_pose_gap_ms"] = optional(s.max_pose_gap_ms);
  }
  out << json.dump() << "\n";
}

void report_run(const RunResult& result, const FeatureMap2D& map, bool json, const std::string& plot_file) {
  if (json) {
    write_json(std::cout, result);
  } else {
    write_summary(std::cout, result);
  }
  if (plot_file.empty()) return;
  plot_run(plot_file, map, result);
  (json ? std::cerr : std::cout) << "plot: " << plot_file << std::endl;
}

void write_trace(const std::string& csv_file, const RunResult& result) {
  std::ofstream out(csv_file);
  if (!out) throw std::runtime_error("cannot write trace '" + csv_file + "'");
  out << "t_s,x_m,y_m,yaw_rad,truth_x_m,truth_y_m,truth_yaw_rad,error_m,heading_error_rad,var_x,var_y,cov_xy,var_yaw,"
         "nees_position,nees_heading,state\n";
  out << std::setprecision(9);
  for (const ScoredEstimate& e : result.estimates) {
    out << e.t << "," << e.estimate.x << "," << e.estimate.y << "," << e.estimate.theta << "," << e.truth.x << ","
        << e.truth.y << "," << e.truth.theta << "," << e.position_error_m << "," << e.heading_error_rad << ","
        << e.covariance(0, 0) << "," << e.covariance(1, 1) << "," << e.covariance(0, 1) << "," << e.covariance(2, 2)
        << "," << e.nees.position << ",";
    if (e.nees.heading) out << *e.nees.heading;
    out << "," << localization_state_name(e.state) << "\n";
  }
  if (!out) throw std::runtime_error("cannot write trace '" + csv_file + "'");
}

void write_localization_summary(std::ostream& out, const StateSummary& l, const std::optional<SimulatedEvent>& event) {
  write_state_summary(out, l);
  if (event && l.samples) {
    out << std::setprecision(1) << "  " << (event->kind == "kidnap" ? "kidnap" : "wrong start") << " at t = " << event->t
        << " s, " << event->distance_m << " m: ";
    if (l.detection_delay_s) {
      out << "uncertain or lost after " << std::setprecision(2) << *l.detection_delay_s << " s";
    } else {
      out << "never reported uncertain or lost";
    }
    if (l.relocalization_delay_s) {
      out << ", relocalized after " << std::setprecision(2) << *l.relocalization_delay_s << " s\n";
    } else {
      out << ", not relocalized\n";
    }
  }
  out << std::setprecision(3);
}

void write_summary(std::ostream& out, const RunResult& r) {
  const EvaluationSummary& s = r.summary;
  out << std::fixed << std::setprecision(3);
  out << "scenario " << r.scenario << ", robot " << r.robot_id << ", plugin " << r.plugin << ", seed " << r.seed
      << ", " << r.duration_s << " s\n";
  out << "  measurements " << r.measurements << " (rejected " << r.rejected << "), estimates " << s.updates << "\n";
  if (r.rejected) out << "  last rejection: " << r.last_rejection << "\n";
  out << "  position error: mean " << s.mean_error_m << " m, rmse " << s.rmse_m << " m, p95 " << s.p95_error_m
      << " m, max " << s.max_error_m << " m, final " << s.final_error_m << " m\n";
  out << "  heading error: mean " << s.mean_heading_error_deg << " deg\n";
  out << "  update: p50 " << s.update_ms_p50 << " ms, p99 " << s.update_ms_p99 << " ms\n";
  if (s.latency_ms_p50) {
    out << "  latency (scan published -> pose received): p50 " << *s.latency_ms_p50 << " ms, p99 "
        << *s.latency_ms_p99 << " ms; above the plugin's update: p50 " << *s.overhead_ms_p50 << " ms, p99 "
        << *s.overhead_ms_p99 << " ms\n";
    if (s.max_pose_gap_ms) out << "  longest wait between two poses: " << *s.max_pose_gap_ms << " ms\n";
  }
  if (s.converged) {
    out << "  converged: error below threshold from t = " << *s.convergence_time_s << " s to the end\n";
  } else {
    out << "  not converged (the final error is above the threshold)\n";
  }
  write_consistency_summary(out, s.consistency);
  write_localization_summary(out, s.localization, r.event);
  out << std::defaultfloat;
}

}  // namespace locd::sim
