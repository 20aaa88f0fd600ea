// dataset.cpp — directory defaults, clip names and labels, the manifest (parallel parse of every clip), JSON I/O.
#include "models/data/dataset.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tensor/tensor.h"

namespace fs = std::filesystem;

namespace t2m::data {

double Manifest::total_duration() const {
  double s = 0;
  for (const auto& c : clips) s += c.duration;
  return s;
}

std::string default_cache_dir() {
  if (const char* c = std::getenv("T2M_CACHE"); c && *c) return c;
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/t2m";
  return ".cache/t2m";
}

std::string default_data_dir() {
  if (const char* d = std::getenv("T2M_DATA"); d && *d) return d;
  std::vector<fs::path> candidates = {fs::path("..") / "shared/data/bandai"};
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    candidates.push_back(exe.parent_path() / "../../shared/data/bandai");
    candidates.push_back(exe.parent_path() / "../../../shared/data/bandai");
  }
  for (const auto& c : candidates)
    if (fs::exists(c / "dataset-2.tar.zst", ec) || fs::exists(c / "dataset-1.tar.zst", ec))
      return fs::weakly_canonical(c, ec).string();
  return "";
}

std::vector<std::string> read_label_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("read_label_file: cannot open '" + path + "'");
  std::vector<std::string> out;
  std::string line;
  while (std::getline(f, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    if (!line.empty()) out.push_back(line);
  }
  return out;
}

bool parse_clip_name(const std::string& name, int* dataset, std::string* content, std::string* style, int* take) {
  std::vector<std::string> parts;
  size_t b = 0;
  for (;;) {
    const size_t e = name.find('_', b);
    parts.push_back(name.substr(b, e == std::string::npos ? std::string::npos : e - b));
    if (e == std::string::npos) break;
    b = e + 1;
  }
  if (parts.size() != 4 || (parts[0] != "dataset-1" && parts[0] != "dataset-2")) return false;
  if (parts[1].empty() || parts[2].empty() || parts[3].empty() || parts[3].size() > 6) return false;
  for (char c : parts[3])
    if (c < '0' || c > '9') return false;
  *dataset = parts[0][8] - '0';
  *content = parts[1];
  *style = parts[2];
  *take = std::atoi(parts[3].c_str());
  return true;
}

std::string clip_content(const std::string& name) {
  int dataset = 0, take = 0;
  std::string content, style;
  return parse_clip_name(name, &dataset, &content, &style, &take) ? content : std::string();
}

namespace {

// "dataset-2_walk" -> "walk".
std::string strip_prefix(const std::string& s) {
  const size_t u = s.find('_');
  return (s.rfind("dataset-", 0) == 0 && u != std::string::npos) ? s.substr(u + 1) : s;
}

// Fills everything but frames/duration from the name and <name>.json; returns "" or the reason to skip.
std::string describe_clip(const fs::path& bvh, const Manifest& m, ClipInfo* c) {
  c->name = bvh.stem().string();
  c->bvh_path = bvh.string();
  std::string content, style;
  if (!parse_clip_name(c->name, &c->dataset, &content, &style, &c->take))
    return "name is not dataset-N_<content>_<style>_<take>";
  fs::path js = bvh;
  js.replace_extension(".json");
  std::ifstream f(js);
  if (!f) return "missing " + js.filename().string();
  nlohmann::json j;
  try {
    f >> j;
    c->content = j.at("content").get<int>();
    c->style = j.at("style").get<int>();
  } catch (const std::exception& e) {
    return "bad " + js.filename().string() + ": " + e.what();
  }
  const auto& cl = m.content_labels[c->dataset - 1];
  const auto& sl = m.style_labels[c->dataset - 1];
  if (!cl.empty()) {
    if (c->content < 0 || c->content >= (int)cl.size())
      return "content id " + std::to_string(c->content) + " outside the label list";
    if (cl[c->content] != content)
      return "content id " + std::to_string(c->content) + " ('" + cl[c->content] + "') disagrees with the name";
  }
  if (!sl.empty()) {
    if (c->style < 0 || c->style >= (int)sl.size())
      return "style id " + std::to_string(c->style) + " outside the label list";
    if (sl[c->style] != style)
      return "style id " + std::to_string(c->style) + " ('" + sl[c->style] + "') disagrees with the name";
  }
  c->content_label = content;
  c->style_label = style;
  return "";
}

}  // namespace

Manifest build_manifest(const std::string& root, const std::string& data_dir, int threads) {
  Manifest m;
  m.root = root;
  for (int n = 1; n <= 2; ++n) {
    const fs::path cfg = fs::path(data_dir) / "cfg";
    const std::string p = "dataset-" + std::to_string(n);
    std::error_code ec;
    if (!data_dir.empty() && fs::exists(cfg / (p + "_content_label.txt"), ec)) {
      for (auto& s : read_label_file((cfg / (p + "_content_label.txt")).string()))
        m.content_labels[n - 1].push_back(strip_prefix(s));
      for (auto& s : read_label_file((cfg / (p + "_style_label.txt")).string()))
        m.style_labels[n - 1].push_back(strip_prefix(s));
    }
  }
  std::vector<fs::path> files;
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw Error("build_manifest: '" + root + "' is not a directory");
  for (auto it = fs::recursive_directory_iterator(root, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file() && it->path().extension() == ".bvh") files.push_back(it->path());
  if (ec) throw Error("build_manifest: cannot list '" + root + "': " + ec.message());
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) { return a.stem() < b.stem(); });

  const int n = (int)files.size();
  std::vector<ClipInfo> info(n);
  std::vector<std::string> why(n);
  const int nt = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 4) num_threads(nt)
  for (int i = 0; i < n; ++i) {
    why[i] = describe_clip(files[i], m, &info[i]);
    if (!why[i].empty()) continue;
    try {
      sim::Motion mo = sim::motion_from_bvh(sim::read_bvh(files[i].string()));
      if (mo.frames < 1) throw Error("no frames");
      info[i].frames = mo.frames;
      info[i].duration = mo.frames / mo.fps;
    } catch (const std::exception& e) {
      why[i] = e.what();
    }
  }
  for (int i = 0; i < n; ++i) {
    if (why[i].empty()) {
      m.clips.push_back(std::move(info[i]));
    } else {
      m.skipped.push_back(files[i].stem().string() + ": " + why[i]);
    }
  }
  return m;
}

void save_manifest(const Manifest& m, const std::string& path) {
  nlohmann::json j;
  j["version"] = 1;
  const fs::path base = fs::path(path).parent_path();
  for (int n = 0; n < 2; ++n) {
    j["content_labels"][std::to_string(n + 1)] = m.content_labels[n];
    j["style_labels"][std::to_string(n + 1)] = m.style_labels[n];
  }
  j["clips"] = nlohmann::json::array();
  for (const auto& c : m.clips) {
    std::error_code ec;
    fs::path rel = fs::relative(c.bvh_path, base, ec);
    j["clips"].push_back({{"name", c.name},
                          {"dataset", c.dataset},
                          {"content", c.content},
                          {"style", c.style},
                          {"content_label", c.content_label},
                          {"style_label", c.style_label},
                          {"take", c.take},
                          {"frames", c.frames},
                          {"duration", c.duration},
                          {"bvh", (ec || rel.empty()) ? c.bvh_path : rel.string()}});
  }
  j["skipped"] = m.skipped;
  const std::string text = j.dump(1);
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::error_code ec;
  if (!base.empty()) fs::create_directories(base, ec);
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw Error("save_manifest: cannot create '" + tmp + "'");
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw Error("save_manifest: cannot write '" + path + "'");
  }
}

Manifest load_manifest(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("load_manifest: cannot open '" + path + "'");
  Manifest m;
  m.root = fs::path(path).parent_path().string();
  try {
    nlohmann::json j;
    f >> j;
    if (j.at("version").get<int>() != 1) throw Error("unsupported version");
    for (int n = 0; n < 2; ++n) {
      m.content_labels[n] = j.at("content_labels").at(std::to_string(n + 1)).get<std::vector<std::string>>();
      m.style_labels[n] = j.at("style_labels").at(std::to_string(n + 1)).get<std::vector<std::string>>();
    }
    for (const auto& c : j.at("clips")) {
      ClipInfo ci;
      ci.name = c.at("name").get<std::string>();
      ci.dataset = c.at("dataset").get<int>();
      ci.content = c.at("content").get<int>();
      ci.style = c.at("style").get<int>();
      ci.content_label = c.at("content_label").get<std::string>();
      ci.style_label = c.at("style_label").get<std::string>();
      ci.take = c.at("take").get<int>();
      ci.frames = c.at("frames").get<int>();
      ci.duration = c.at("duration").get<double>();
      fs::path p = c.at("bvh").get<std::string>();
      ci.bvh_path = p.is_absolute() ? p.string() : (fs::path(m.root) / p).string();
      if (ci.dataset != 1 && ci.dataset != 2) throw Error("clip " + ci.name + " has dataset " + std::to_string(ci.dataset));
      m.clips.push_back(std::move(ci));
    }
    m.skipped = j.at("skipped").get<std::vector<std::string>>();
  } catch (const std::exception& e) {
    throw Error("load_manifest: '" + path + "': " + e.what());
  }
  return m;
}

Manifest prepare_dataset(const std::string& data_dir, const std::string& cache_dir, bool force) {
  const std::string root = unpack_dataset(data_dir, cache_dir);
  const fs::path mpath = fs::path(root) / "manifest.json";
  std::error_code ec;
  if (!force && fs::exists(mpath, ec)) {
    bool fresh = true;
    for (int n = 1; n <= 2; ++n) {
      const fs::path marker = fs::path(root) / (".unpacked-dataset-" + std::to_string(n));
      if (fs::exists(marker, ec) && fs::last_write_time(marker, ec) > fs::last_write_time(mpath, ec)) fresh = false;
    }
    if (fresh) return load_manifest(mpath.string());
  }
  Manifest m = build_manifest(root, data_dir);
  save_manifest(m, mpath.string());
  return m;
}

sim::Motion load_clip(const ClipInfo& clip) { return sim::motion_from_bvh(sim::read_bvh(clip.bvh_path)); }

}  // namespace t2m::data
