// train_log.cpp — append-and-flush JSON lines; SVG built as text with fixed-precision coordinates.
#include "nn/train_log.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "nn/checkpoint.h"
#include "tensor/tensor.h"

namespace t2m::nn {

TrainLog::TrainLog(std::string path, int64_t resume_step) : path_(std::move(path)) {
  if (resume_step >= 0 && std::filesystem::exists(path_)) {
    std::string kept;
    for (const auto& r : read_train_log(path_))
      if (!(r.contains("step") && r["step"].is_number() && r["step"].get<double>() > (double)resume_step))
        kept += r.dump() + "\n";
    write_file_atomic(path_, kept);
  }
  f_ = std::fopen(path_.c_str(), "ab");
  if (!f_) throw Error("train log " + path_ + ": cannot open for appending");
}

TrainLog::~TrainLog() {
  if (f_) std::fclose(f_);
}

void TrainLog::write(const nlohmann::json& record) {
  if (!record.is_object()) throw Error("train log " + path_ + ": a record must be a JSON object, got " + record.dump());
  const std::string line = record.dump() + "\n";
  if (std::fwrite(line.data(), 1, line.size(), f_) != line.size() || std::fflush(f_) != 0)
    throw Error("train log " + path_ + ": write failed");
}

std::vector<nlohmann::json> read_train_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("train log " + path + ": cannot open");
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<nlohmann::json> out;
  size_t pos = 0;
  int64_t lineno = 0;
  while (pos < all.size()) {
    const size_t nl = all.find('\n', pos);
    const bool complete = nl != std::string::npos;
    const std::string line = all.substr(pos, complete ? nl - pos : std::string::npos);
    pos = complete ? nl + 1 : all.size();
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    nlohmann::json j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) {
      if (!complete) break;  // a crash mid-write: the partial last line is dropped
      throw Error("train log " + path + ": line " + std::to_string(lineno) + " is not a JSON object: " +
                  line.substr(0, 80));
    }
    out.push_back(std::move(j));
  }
  return out;
}

namespace {

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

std::string coord(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}

}  // namespace

std::string loss_curve_svg(const std::vector<nlohmann::json>& records, const SvgPlotOptions& opt) {
  std::vector<std::string> keys = opt.keys;
  if (keys.empty())
    for (const auto& r : records) {
      if (!r.is_object()) throw Error("loss_curve_svg: a record is not a JSON object");
      for (const auto& [k, v] : r.items())
        if (k != opt.x && v.is_number() && std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
    }
  // Series of (x, y) in y's plotting space (log10 when log_y).
  std::vector<std::vector<std::pair<double, double>>> series(keys.size());
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& r : records) {
    if (!r.is_object()) throw Error("loss_curve_svg: a record is not a JSON object");
    if (!r.contains(opt.x) || !r[opt.x].is_number()) continue;
    const double x = r[opt.x].get<double>();
    if (!std::isfinite(x)) continue;
    for (size_t k = 0; k < keys.size(); ++k) {
      if (!r.contains(keys[k]) || !r[keys[k]].is_number()) continue;
      double y = r[keys[k]].get<double>();
      if (!std::isfinite(y) || (opt.log_y && y <= 0)) continue;
      if (opt.log_y) y = std::log10(y);
      series[k].emplace_back(x, y);
      x0 = std::min(x0, x); x1 = std::max(x1, x); y0 = std::min(y0, y); y1 = std::max(y1, y);
    }
  }
  if (!(x0 <= x1)) throw Error("loss_curve_svg: nothing to plot (no record has '" + opt.x + "' and a numeric value)");
  if (x1 == x0) { x0 -= 0.5; x1 += 0.5; }
  if (y1 == y0) { y0 -= 0.5; y1 += 0.5; }
  const double W = opt.width, H = opt.height, L = 70, R = 150, T = 30, B = 45;
  auto px = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
  auto py = [&](double y) { return H - B - (y - y0) / (y1 - y0) * (H - T - B); };
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};
  std::ostringstream s;
  s << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" << opt.width << "\" height=\"" << opt.height
    << "\" viewBox=\"0 0 " << opt.width << " " << opt.height << "\" font-family=\"sans-serif\" font-size=\"11\">\n"
    << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  if (!opt.title.empty()) s << "<text x=\"" << coord(W / 2) << "\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">" << esc(opt.title) << "</text>\n";
  s << "<g stroke=\"black\" fill=\"none\"><line x1=\"" << L << "\" y1=\"" << H - B << "\" x2=\"" << W - R << "\" y2=\"" << H - B
    << "\"/><line x1=\"" << L << "\" y1=\"" << T << "\" x2=\"" << L << "\" y2=\"" << H - B << "\"/></g>\n";
  for (int i = 0; i <= 4; ++i) {  // 5 ticks per axis
    const double xv = x0 + (x1 - x0) * i / 4, yv = y0 + (y1 - y0) * i / 4;
    s << "<text x=\"" << coord(px(xv)) << "\" y=\"" << coord(H - B + 16) << "\" text-anchor=\"middle\">" << num(xv) << "</text>\n";
    s << "<line x1=\"" << L << "\" y1=\"" << coord(py(yv)) << "\" x2=\"" << W - R << "\" y2=\"" << coord(py(yv))
      << "\" stroke=\"#dddddd\"/>\n";
    s << "<text x=\"" << L - 6 << "\" y=\"" << coord(py(yv) + 4) << "\" text-anchor=\"end\">"
      << num(opt.log_y ? std::pow(10.0, yv) : yv) << "</text>\n";
  }
  s << "<text x=\"" << coord((L + W - R) / 2) << "\" y=\"" << H - 8 << "\" text-anchor=\"middle\">" << esc(opt.x) << "</text>\n";
  for (size_t k = 0; k < keys.size(); ++k) {
    if (series[k].empty()) continue;
    const char* c = colors[k % 8];
    s << "<polyline fill=\"none\" stroke=\"" << c << "\" stroke-width=\"1.5\" points=\"";
    for (size_t i = 0; i < series[k].size(); ++i)
      s << (i ? " " : "") << coord(px(series[k][i].first)) << "," << coord(py(series[k][i].second));
    s << "\"/>\n";
    const double ly = T + 16.0 * (double)k + 8;
    s << "<line x1=\"" << W - R + 10 << "\" y1=\"" << coord(ly) << "\" x2=\"" << W - R + 30 << "\" y2=\"" << coord(ly)
      << "\" stroke=\"" << c << "\" stroke-width=\"2\"/><text x=\"" << W - R + 35 << "\" y=\"" << coord(ly + 4) << "\">"
      << esc(keys[k]) << (opt.log_y ? " (log)" : "") << "</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

void write_loss_svg(const std::string& log_path, const std::string& svg_path, const SvgPlotOptions& opt) {
  write_file_atomic(svg_path, loss_curve_svg(read_train_log(log_path), opt));
}

}  // namespace t2m::nn
