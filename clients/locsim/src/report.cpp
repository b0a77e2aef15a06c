#include "locd/sim/report.hpp"

#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

namespace locd::sim {

namespace {

std::string json_string(const std::string& s) {
  std::ostringstream out;
  out << '"';
  for (const char c : s) {
    switch (c) {
      case '"': out << "\\\""; break;
      case '\\': out << "\\\\"; break;
      case '\n': out << "\\n"; break;
      case '\t': out << "\\t"; break;
      case '\r': out << "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out << "\\u" << std::hex << std::setw(4) << std::setfill('0') << static_cast<int>(c) << std::dec;
        } else {
          out << c;
        }
    }
  }
  out << '"';
  return out.str();
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream out;
  out << std::setprecision(6) << v;
  return out.str();
}

std::string json_number(const std::optional<double>& v) { return v ? json_number(*v) : "null"; }

}  // namespace

void write_json(std::ostream& out, const RunResult& r) {
  const EvaluationSummary& s = r.summary;
  std::vector<std::pair<std::string, std::string>> fields = {
      {"plugin", json_string(r.plugin)},
      {"scenario", json_string(r.scenario)},
      {"robot", json_string(r.robot_id)},
      {"seed", std::to_string(r.seed)},
      {"duration_s", json_number(r.duration_s)},
      {"measurements", std::to_string(r.measurements)},
      {"rejected", std::to_string(r.rejected)},
      {"updates", std::to_string(s.updates)},
      {"mean_error_m", json_number(s.mean_error_m)},
      {"rmse_m", json_number(s.rmse_m)},
      {"p95_error_m", json_number(s.p95_error_m)},
      {"max_error_m", json_number(s.max_error_m)},
      {"final_error_m", json_number(s.final_error_m)},
      {"mean_heading_error_deg", json_number(s.mean_heading_error_deg)},
      {"update_ms_p50", json_number(s.update_ms_p50)},
      {"update_ms_p99", json_number(s.update_ms_p99)},
      {"converged", s.converged ? "true" : "false"},
      {"convergence_time_s", json_number(s.convergence_time_s)},
  };
  if (s.latency_ms_p50) {
    fields.push_back({"latency_ms_p50", json_number(s.latency_ms_p50)});
    fields.push_back({"latency_ms_p99", json_number(s.latency_ms_p99)});
    fields.push_back({"overhead_ms_p50", json_number(s.overhead_ms_p50)});
    fields.push_back({"overhead_ms_p99", json_number(s.overhead_ms_p99)});
  }
  out << "{";
  for (size_t i = 0; i < fields.size(); ++i) {
    out << (i ? ", " : "") << json_string(fields[i].first) << ": " << fields[i].second;
  }
  out << "}\n";
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
  }
  if (s.converged) {
    out << "  converged: error below threshold from t = " << *s.convergence_time_s << " s to the end\n";
  } else {
    out << "  not converged (the final error is above the threshold)\n";
  }
  out << std::defaultfloat;
}

}  // namespace locd::sim
