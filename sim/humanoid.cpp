// humanoid.cpp — generates the MJCF of our humanoid from humanoid_spec.cpp and compiles models (inline or file).
#include "sim/humanoid.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <vector>

#include "sim/skeleton.h"
#include "tensor/tensor.h"

namespace t2m::sim {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kSoleBelowAnkle = 0.118;  // sole depth below the ankle joint (Bandai planted ankle: 0.117 m)
constexpr double kToeSoleBelowJoint = 0.042;  // sole below the toe joint (Bandai planted toe joint: 0.0425 m)
const char* kAxisName[3] = {"x", "y", "z"};

struct V3 {
  double x, y, z;
};
V3 rel(int child, int j) {
  const auto& a = rest_joint_pos(child);
  const auto& b = rest_joint_pos(j);
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
int first_child(int j) {
  const auto& s = humanoid_joint_spec();
  for (int k = j + 1; k < kHumanoidBodies; ++k)
    if (s[k].parent == j) return k;
  return -1;
}
std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", std::abs(v) < 1e-9 ? 0.0 : v);
  return b;
}
std::string fmt_dt() {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", kPhysicsDt);
  return b;
}
std::string vec(V3 v) { return num(v.x) + " " + num(v.y) + " " + num(v.z); }

// Capsule from the body origin to `to` with radius r.
std::string capsule(const std::string& name, V3 from, V3 to, double r) {
  return "<geom name=\"" + name + "\" type=\"capsule\" fromto=\"" + vec(from) + " " + vec(to) + "\" size=\"" +
         num(r) + "\"/>";
}
// Planted-foot pitch: the data's feet, when planted, are pitched toe-up relative to the reference pose (median over
// the planted frames of every 4th clip: ankle speed < 5 cm/s and ankle < 14 cm high; foot 6.3 deg, toes 6.4 deg,
// roll < 1 deg). The sole boxes are tilted toe-down by that much in the body frame, so they lie flat on the floor
// when the foot is planted (with flat boxes in the reference pose the standing feet touched with the heel edge only
// and the body tipped forward about it).
constexpr double kFootSolePitchDeg = 6.3;
constexpr double kToesSolePitchDeg = 6.4;
double sole_pitch(double deg) { return deg * M_PI / 180; }
constexpr double kHeel = -0.055, kFootTop = -0.06;   // foot box: heel behind the ankle, top below it (m)
constexpr double kToesLength = 0.06, kToesTop = -0.012;

// Hips height with flat (unpitched) soles on the floor in the reference pose.
double flat_sole_hips_height() {
  const double ankle = std::min(rest_joint_pos(15)[2], rest_joint_pos(19)[2]);
  return -(ankle - kSoleBelowAnkle);
}
// Toes box depth below the toe joint: its flat sole on that floor plane (the toe joint is 3.4 cm up there).
double toes_sole_depth(int toes) {
  return std::min(kToeSoleBelowJoint, flat_sole_hips_height() + rest_joint_pos(toes)[2]);
}
// A body-frame point after rotating it about the body origin by `pitch` about y (toe down for pitch > 0).
V3 pitched(V3 p, double pitch) {
  const double cs = std::cos(pitch), sn = std::sin(pitch);
  return {cs * p.x + sn * p.z, p.y, -sn * p.x + cs * p.z};
}

// Box with half sizes `half`, centred at c after rotating the body-frame box about the body origin by `pitch`
// about y (toe down for pitch > 0).
std::string sole_box(const std::string& name, V3 c, V3 half, double pitch) {
  return "<geom name=\"" + name + "\" type=\"box\" pos=\"" + vec(pitched(c, pitch)) + "\" size=\"" + vec(half) + "\" euler=\"0 " +
         num(pitch) + " 0\"/>";
}

// The geoms of body j (body frame = world axes in the reference pose, origin at the joint).
std::string body_geoms(int j) {
  const auto& s = humanoid_joint_spec();
  const std::string n = s[j].name;
  const V3 o{0, 0, 0};
  const int c = first_child(j);
  auto starts = [&](const char* p) { return n.rfind(p, 0) == 0; };
  if (n == "Hips") {
    std::string g = capsule("Hips_pelvis", rel(13, 0), rel(17, 0), 0.095);
    return g;
  }
  if (n == "Spine") return capsule("Spine_geom", o, rel(c, j), 0.085);
  if (n == "Chest") {
    return capsule("Chest_geom", o, rel(3, j), 0.10) + capsule("Chest_shoulders", rel(5, j), rel(9, j), 0.065);
  }
  if (n == "Neck") return capsule("Neck_geom", o, rel(c, j), 0.045);
  if (n == "Head") return "<geom name=\"Head_geom\" type=\"sphere\" pos=\"0.02 0 0.08\" size=\"0.095\"/>";
  if (starts("Shoulder")) return capsule(n + "_geom", o, rel(c, j), 0.045);
  if (starts("UpperArm")) return capsule(n + "_geom", o, rel(c, j), 0.045);
  if (starts("LowerArm")) return capsule(n + "_geom", o, rel(c, j), 0.038);
  if (starts("Hand")) {
    const V3 d = rel(j, s[j].parent);  // continue the forearm direction
    const double L = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    const double k = 0.08 / L;
    return capsule(n + "_geom", o, {d.x * k, d.y * k, d.z * k}, 0.035);
  }
  if (starts("UpperLeg")) return capsule(n + "_geom", o, rel(c, j), 0.065);
  if (starts("LowerLeg")) return capsule(n + "_geom", o, rel(c, j), 0.05);
  if (starts("Foot")) {
    const V3 t = rel(c, j);  // toe joint
    return sole_box(n + "_geom", {(kHeel + t.x) / 2, t.y / 2, (kFootTop - kSoleBelowAnkle) / 2},
                    {(t.x - kHeel) / 2, 0.045, (kFootTop + kSoleBelowAnkle) / 2}, sole_pitch(kFootSolePitchDeg));
  }
  if (starts("Toes")) {
    const double depth = toes_sole_depth(j);
    return sole_box(n + "_geom", {kToesLength / 2, 0, (-depth - kToesTop) / 2}, {kToesLength / 2, 0.045, (depth - kToesTop) / 2},
                    sole_pitch(kToesSolePitchDeg));
  }
  throw Error("humanoid_mjcf: no geometry rule for joint " + n);
}

// Names of the <geom name="..."> elements in an XML fragment, in order.
void collect_geom_names(const std::string& xml, std::vector<std::string>& names) {
  const std::string key = "<geom name=\"";
  for (size_t p = xml.find(key); p != std::string::npos; p = xml.find(key, p + 1)) {
    const size_t b = p + key.size();
    names.push_back(xml.substr(b, xml.find('"', b) - b));
  }
}

void emit_body(std::ostringstream& x, int j, const HumanoidOptions& opt, int depth,
               std::vector<std::string>& geoms) {
  const auto& s = humanoid_joint_spec();
  const std::string ind(2 * depth, ' ');
  const V3 p = j == 0 ? V3{0, 0, humanoid_hips_height()} : rel(j, s[j].parent);
  x << ind << "<body name=\"" << s[j].name << "\" pos=\"" << vec(p) << "\">\n";
  if (j == 0) {
    x << ind << "  <freejoint name=\"root\"/>\n";
  } else {
    const double kp = s[j].kp * opt.gain_scale;
    for (int i = 0; i < 3; ++i) {
      const int a = s[j].order[i];
      x << ind << "  <joint name=\"" << s[j].name << "_" << kAxisName[a] << "\" axis=\"" << (a == 0) << " "
        << (a == 1) << " " << (a == 2) << "\" range=\"" << num(s[j].range_deg[i][0] * kDeg) << " "
        << num(s[j].range_deg[i][1] * kDeg) << "\" damping=\"" << num(kp / 10) << "\"/>\n";
    }
  }
  const std::string g = body_geoms(j);
  collect_geom_names(g, geoms);
  x << ind << "  " << g << "\n";
  for (int k = j + 1; k < kHumanoidBodies; ++k)
    if (s[k].parent == j) emit_body(x, k, opt, depth + 1, geoms);
  x << ind << "</body>\n";
}

}  // namespace

double humanoid_hips_height() {
  // The lowest corner of the pitched foot and toes boxes in the reference pose touches the floor.
  double lowest = 0;
  for (int foot : {15, 19}) {
    const int toes = foot + 1;
    const double tx = rest_joint_pos(toes)[0] - rest_joint_pos(foot)[0];
    const double fp = sole_pitch(kFootSolePitchDeg), tp = sole_pitch(kToesSolePitchDeg);
    for (double x : {kHeel, tx})
      for (double z : {kFootTop, -kSoleBelowAnkle}) lowest = std::min(lowest, rest_joint_pos(foot)[2] + pitched({x, 0, z}, fp).z);
    for (double x : {0.0, kToesLength})
      for (double z : {kToesTop, -toes_sole_depth(toes)})
        lowest = std::min(lowest, rest_joint_pos(toes)[2] + pitched({x, 0, z}, tp).z);
  }
  return -lowest;
}

std::vector<float> humanoid_offsets() {
  const auto& spec = humanoid_joint_spec();
  std::vector<float> out(kHumanoidBodies * 3, 0.f);
  for (int j = 0; j < kHumanoidBodies; ++j) {
    double o[3] = {0, 0, 0};
    if (j == 0) {
      o[2] = humanoid_hips_height();
    } else {
      bvh_to_world_vec(spec[j].offset_bvh_cm, o);
    }
    for (int k = 0; k < 3; ++k) out[3 * j + k] = float(o[k]);
  }
  return out;
}

std::string humanoid_mjcf(const HumanoidOptions& opt) {
  const char* solver = opt.solver == mjSOL_PGS ? "PGS" : opt.solver == mjSOL_NEWTON ? "Newton"
                       : opt.solver == mjSOL_CG   ? "CG"
                                                  : nullptr;
  if (!solver || opt.solver_iterations < 1 || !(opt.gain_scale > 0) || !(opt.floor_friction > 0))
    throw Error("humanoid_mjcf: bad options (solver " + std::to_string(opt.solver) + ", iterations " +
                std::to_string(opt.solver_iterations) + ", gain_scale " + num(opt.gain_scale) + ", friction " +
                num(opt.floor_friction) + ")");
  const auto& s = humanoid_joint_spec();
  std::ostringstream x;
  x << "<mujoco model=\"t2m_humanoid\">\n"
    << "  <compiler angle=\"radian\" inertiafromgeom=\"true\"/>\n"
    << "  <option timestep=\"" << fmt_dt() << "\" integrator=\"" << (opt.euler ? "Euler" : "implicit")
    << "\" solver=\"" << solver << "\" iterations=\"" << opt.solver_iterations << "\" tolerance=\"1e-8\""
    << " cone=\"" << (opt.elliptic_cones ? "elliptic" : "pyramidal") << "\""
    << (opt.self_collision ? "" : " collision=\"predefined\"") << "/>\n"
    << "  <size njmax=\"400\" nconmax=\"100\"/>\n"
    << "  <visual><quality shadowsize=\"2048\"/><map znear=\"0.01\"/></visual>\n"
    << "  <default>\n"
    << "    <joint type=\"hinge\" limited=\"true\" armature=\"0.02\"/>\n"
    << "    <geom contype=\"" << (opt.self_collision ? 3 : 1) << "\" conaffinity=\""
    << (opt.self_collision ? 2 : 0) << "\" condim=\"3\" density=\"1000\" friction=\"" << num(opt.floor_friction)
    << " 0.005 0.0001\" rgba=\"0.8 0.6 0.45 1\"/>\n"
    << "    <position ctrllimited=\"true\" forcelimited=\"true\"/>\n"
    << "  </default>\n"
    << "  <asset>\n"
    << "    <texture name=\"grid\" type=\"2d\" builtin=\"checker\" rgb1=\"0.25 0.3 0.35\" rgb2=\"0.4 0.45 0.5\" "
       "width=\"512\" height=\"512\"/>\n"
    << "    <material name=\"grid\" texture=\"grid\" texrepeat=\"1 1\" texuniform=\"true\" reflectance=\"0.1\"/>\n"
    << "  </asset>\n"
    << "  <worldbody>\n"
    << "    <light name=\"sun\" directional=\"true\" pos=\"0 0 5\" dir=\"-0.3 0.2 -1\" castshadow=\"true\"/>\n"
    << "    <geom name=\"floor\" type=\"plane\" size=\"100 100 0.1\" material=\"grid\" rgba=\"1 1 1 1\" contype=\"1\" "
       "conaffinity=\"1\"/>\n";
  std::vector<std::string> geoms;
  emit_body(x, 0, opt, 2, geoms);
  x << "  </worldbody>\n";
  if (!opt.self_collision) {
    // Body-floor contacts as explicit pairs (collision="predefined" skips the broadphase: -3.6 % instructions per
    // step). Pair parameters = what the dynamic geom-geom contact would mix from the geoms: condim 3, friction
    // (f, f, 0.005, 0.0001, 0.0001), default solref/solimp, margin 0, so the contacts are the same.
    const std::string f = num(opt.floor_friction);
    x << "  <contact>\n";
    for (const auto& g : geoms)
      x << "    <pair geom1=\"floor\" geom2=\"" << g << "\" condim=\"3\" friction=\"" << f << " " << f
        << " 0.005 0.0001 0.0001\"/>\n";
    x << "  </contact>\n";
  }
  x << "  <actuator>\n";
  for (int j = 1; j < kHumanoidBodies; ++j) {
    const double kp = s[j].kp * opt.gain_scale;
    for (int i = 0; i < 3; ++i) {
      const std::string jn = std::string(s[j].name) + "_" + kAxisName[s[j].order[i]];
      x << "    <position name=\"" << jn << "\" joint=\"" << jn << "\" kp=\"" << num(kp) << "\" ctrlrange=\""
        << num(s[j].range_deg[i][0] * kDeg) << " " << num(s[j].range_deg[i][1] * kDeg) << "\" forcerange=\""
        << num(-kp) << " " << num(kp) << "\"/>\n";
    }
  }
  x << "  </actuator>\n</mujoco>\n";
  return x.str();
}

// ---- Humanoid (compiled model wrapper) ----

std::shared_ptr<const Humanoid> Humanoid::from_xml(const std::string& xml) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const char* fname = "t2m_inline_model.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), fname, (int)xml.size()) != 0) throw Error("Humanoid::from_xml: VFS full");
  const int idx = mj_findFileVFS(vfs.get(), fname);
  std::memcpy(vfs->filedata[idx], xml.data(), xml.size());
  char err[1024] = {0};
  mjModel* m = mj_loadXML(fname, vfs.get(), err, sizeof err);
  mj_deleteVFS(vfs.get());
  if (!m) throw Error(std::string("Humanoid::from_xml: MuJoCo could not compile the model: ") + err);
  return std::shared_ptr<const Humanoid>(new Humanoid(m));
}

std::shared_ptr<const Humanoid> Humanoid::from_file(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw Error("Humanoid::from_file: no such model file '" + path + "'");
  char err[1024] = {0};
  mjModel* m = mj_loadXML(path.c_str(), nullptr, err, sizeof err);
  if (!m) throw Error("Humanoid::from_file: MuJoCo could not compile '" + path + "': " + err);
  return std::shared_ptr<const Humanoid>(new Humanoid(m));
}

std::shared_ptr<const Humanoid> Humanoid::create(const HumanoidOptions& opt) { return from_xml(humanoid_mjcf(opt)); }

Humanoid::Humanoid(mjModel* m) : m_(m) {
  const auto& s = humanoid_joint_spec();
  std::vector<int> ids;
  for (int j = 0; j < kHumanoidBodies; ++j) ids.push_back(mj_name2id(m, mjOBJ_BODY, s[j].name));
  humanoid_ = true;
  for (int id : ids) humanoid_ = humanoid_ && id >= 0;
  if (humanoid_) {
    for (int j = 1; j < kHumanoidBodies && humanoid_; ++j)
      for (int i = 0; i < 3; ++i) {
        const std::string jn = std::string(s[j].name) + "_" + kAxisName[s[j].order[i]];
        const int jid = mj_name2id(m, mjOBJ_JOINT, jn.c_str());
        if (jid < 0 || m->jnt_type[jid] != mjJNT_HINGE) {
          humanoid_ = false;
          break;
        }
        hinge_qpos_.push_back(m->jnt_qposadr[jid]);
        hinge_dof_.push_back(m->jnt_dofadr[jid]);
      }
  }
  if (humanoid_) {
    bodies_ = ids;
  } else {
    hinge_qpos_.clear();
    hinge_dof_.clear();
    for (int b = 1; b < m->nbody; ++b) bodies_.push_back(b);
  }
  if (!bodies_.empty()) {
    const int b = bodies_[0];
    if (m->body_jntnum[b] >= 1 && m->jnt_type[m->body_jntadr[b]] == mjJNT_FREE) {
      root_qpos_ = m->jnt_qposadr[m->body_jntadr[b]];
      root_dof_ = m->jnt_dofadr[m->body_jntadr[b]];
    }
  }
}

Humanoid::~Humanoid() {
  if (m_) mj_deleteModel(m_);
}

double model_total_mass(const mjModel* m) {
  double s = 0;
  for (int b = 0; b < m->nbody; ++b) s += m->body_mass[b];
  return s;
}

}  // namespace t2m::sim
