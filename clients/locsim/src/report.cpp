#include "locd/sim/report.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

namespace locd::sim {

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
  out << std::defaultfloat;
}

}  // namespace locd::sim
