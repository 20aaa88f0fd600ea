// render.cpp — EGL (dlopen) surfaceless context + mjr offscreen buffer; frames piped into ffmpeg.
#include "sim/render.h"

#include <EGL/egl.h>
#include <dlfcn.h>

#include <csignal>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "tensor/tensor.h"

namespace t2m::sim {

namespace {

struct Egl {
  void* lib = nullptr;
  PFNEGLGETPROCADDRESSPROC getProcAddress = nullptr;
  PFNEGLGETDISPLAYPROC getDisplay = nullptr;
  PFNEGLINITIALIZEPROC initialize = nullptr;
  PFNEGLCHOOSECONFIGPROC chooseConfig = nullptr;
  PFNEGLBINDAPIPROC bindAPI = nullptr;
  PFNEGLCREATECONTEXTPROC createContext = nullptr;
  PFNEGLMAKECURRENTPROC makeCurrent = nullptr;
  PFNEGLDESTROYCONTEXTPROC destroyContext = nullptr;
  PFNEGLTERMINATEPROC terminate = nullptr;
  PFNEGLGETERRORPROC getError = nullptr;
};

template <class F>
void load(void* lib, F& f, const char* name) {
  f = reinterpret_cast<F>(dlsym(lib, name));
  if (!f) throw Error(std::string("Renderer: libEGL has no ") + name);
}

Egl load_egl() {
  Egl e;
  e.lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_GLOBAL);
  if (!e.lib) throw Error(std::string("Renderer: cannot load libEGL.so.1 (install libegl1): ") + dlerror());
  load(e.lib, e.getProcAddress, "eglGetProcAddress");
  load(e.lib, e.getDisplay, "eglGetDisplay");
  load(e.lib, e.initialize, "eglInitialize");
  load(e.lib, e.chooseConfig, "eglChooseConfig");
  load(e.lib, e.bindAPI, "eglBindAPI");
  load(e.lib, e.createContext, "eglCreateContext");
  load(e.lib, e.makeCurrent, "eglMakeCurrent");
  load(e.lib, e.destroyContext, "eglDestroyContext");
  load(e.lib, e.terminate, "eglTerminate");
  load(e.lib, e.getError, "eglGetError");
  return e;
}

}  // namespace

struct Renderer::Impl {
  Egl egl;
  EGLDisplay dpy = EGL_NO_DISPLAY;
  EGLContext ctx = EGL_NO_CONTEXT;
  mjModel* m = nullptr;  // own copy: offscreen buffer size set to the requested frame size
  mjData* d = nullptr;
  mjvScene scn;
  mjvCamera cam;
  mjvOption vopt;
  mjrContext con;
  int root = 0;
  bool scene_made = false, con_made = false;
  std::vector<uint8_t> flip;
  ~Impl() {
    if (con_made) mjr_freeContext(&con);
    if (scene_made) mjv_freeScene(&scn);
    if (d) mj_deleteData(d);
    if (m) mj_deleteModel(m);
    if (ctx != EGL_NO_CONTEXT) {
      egl.makeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      egl.destroyContext(dpy, ctx);
    }
    if (dpy != EGL_NO_DISPLAY) egl.terminate(dpy);
  }
};

Renderer::Renderer(std::shared_ptr<const Humanoid> h, const RenderOptions& opt) : impl_(new Impl), opt_(opt) {
  if (opt.width < 16 || opt.height < 16 || opt.width > 4096 || opt.height > 4096 || opt.width % 2 ||
      opt.height % 2)
    throw Error("Renderer: frame size must be even and in [16, 4096] (got " + std::to_string(opt.width) + "x" +
                std::to_string(opt.height) + ")");
  setenv("EGL_PLATFORM", "surfaceless", 0);
  Impl& I = *impl_;
  I.egl = load_egl();
  I.dpy = I.egl.getDisplay(EGL_DEFAULT_DISPLAY);
  EGLint major = 0, minor = 0;
  if (I.dpy == EGL_NO_DISPLAY || !I.egl.initialize(I.dpy, &major, &minor))
    throw Error("Renderer: eglInitialize failed (EGL error 0x" + std::to_string(I.egl.getError()) + ")");
  const EGLint cfg_attr[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8,
                             EGL_ALPHA_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig cfg;
  EGLint n = 0;
  if (!I.egl.chooseConfig(I.dpy, cfg_attr, &cfg, 1, &n) || n < 1) {
    const EGLint cfg2[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};  // surfaceless: no pbuffer needed
    if (!I.egl.chooseConfig(I.dpy, cfg2, &cfg, 1, &n) || n < 1) throw Error("Renderer: no EGL config for OpenGL");
  }
  if (!I.egl.bindAPI(EGL_OPENGL_API)) throw Error("Renderer: eglBindAPI(OpenGL) failed");
  I.ctx = I.egl.createContext(I.dpy, cfg, EGL_NO_CONTEXT, nullptr);
  if (I.ctx == EGL_NO_CONTEXT) throw Error("Renderer: eglCreateContext failed");
  if (!I.egl.makeCurrent(I.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, I.ctx))
    throw Error("Renderer: eglMakeCurrent (surfaceless) failed");
  I.m = mj_copyModel(nullptr, h->model());
  I.m->vis.global.offwidth = opt.width;
  I.m->vis.global.offheight = opt.height;
  I.d = mj_makeData(I.m);
  mjv_defaultScene(&I.scn);
  mjv_makeScene(I.m, &I.scn, 2000);
  I.scene_made = true;
  mjv_defaultOption(&I.vopt);
  mjv_defaultCamera(&I.cam);
  I.cam.type = mjCAMERA_FREE;  // lookat set to the root every frame (follow camera, no smoothing lag)
  I.root = h->tracked_bodies().empty() ? 0 : h->tracked_bodies()[0];
  I.cam.distance = opt.distance;
  I.cam.elevation = opt.elevation;
  I.cam.azimuth = opt.azimuth;
  mjr_defaultContext(&I.con);
  mjr_makeContext(I.m, &I.con, mjFONTSCALE_100);
  I.con_made = true;
  if (!I.con.offFBO) throw Error("Renderer: MuJoCo could not create an offscreen framebuffer");
  mjr_setBuffer(mjFB_OFFSCREEN, &I.con);
  I.scn.flags[mjRND_SHADOW] = opt.shadows ? 1 : 0;
  I.flip.resize((size_t)opt.width * opt.height * 3);
}

Renderer::~Renderer() = default;

void Renderer::render(const double* qpos, uint8_t* rgb) {
  Impl& I = *impl_;
  mju_copy(I.d->qpos, qpos, I.m->nq);
  mj_kinematics(I.m, I.d);
  mj_camlight(I.m, I.d);
  const double* root = I.d->xpos + 3 * I.root;
  I.cam.lookat[0] = root[0], I.cam.lookat[1] = root[1], I.cam.lookat[2] = std::max(0.6, root[2] * 0.9);
  mjv_updateScene(I.m, I.d, &I.vopt, nullptr, &I.cam, mjCAT_ALL, &I.scn);
  I.scn.flags[mjRND_SHADOW] = opt_.shadows ? 1 : 0;
  const mjrRect vp = {0, 0, opt_.width, opt_.height};
  mjr_render(vp, &I.scn, &I.con);
  mjr_readPixels(I.flip.data(), nullptr, vp, &I.con);
  const size_t row = (size_t)opt_.width * 3;
  for (int y = 0; y < opt_.height; ++y)
    std::copy(I.flip.begin() + (size_t)(opt_.height - 1 - y) * row, I.flip.begin() + (size_t)(opt_.height - y) * row,
              rgb + (size_t)y * row);
}

namespace {
FILE* open_ffmpeg(const std::string& args) {
  const std::string cmd = "ffmpeg -y -loglevel error " + args;
  FILE* f = popen(cmd.c_str(), "w");
  if (!f) throw Error("render: cannot start ffmpeg (" + cmd + ")");
  return f;
}
std::string quote(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}
}  // namespace

int render_trajectory(std::shared_ptr<const Humanoid> h, const QposTrajectory& q, const std::string& mp4_path,
                      const std::string& png_dir, const RenderOptions& opt) {
  const mjModel* m = h->model();
  if (q.nq != m->nq || q.qpos.size() != (size_t)q.frames * m->nq || q.frames < 1 || !(q.fps > 0))
    throw Error("render_trajectory: trajectory of " + std::to_string(q.frames) + " frames, nq " +
                std::to_string(q.nq) + " does not fit the model (nq " + std::to_string(m->nq) + ")");
  if (mp4_path.empty() && png_dir.empty()) throw Error("render_trajectory: neither an MP4 path nor a PNG dir given");
  Renderer r(h, opt);
  // A dying ffmpeg must give an error, not kill us with SIGPIPE.
  struct SigpipeGuard {
    void (*old)(int) = std::signal(SIGPIPE, SIG_IGN);
    ~SigpipeGuard() { std::signal(SIGPIPE, old); }
  } guard;
  const std::string raw = "-f rawvideo -pix_fmt rgb24 -s " + std::to_string(opt.width) + "x" +
                          std::to_string(opt.height) + " -r " + std::to_string(q.fps) + " -i - ";
  const std::string tmp = mp4_path + ".tmp.mp4";
  FILE* mp4 = nullptr;
  FILE* png = nullptr;
  if (!mp4_path.empty()) mp4 = open_ffmpeg(raw + "-c:v libx264 -pix_fmt yuv420p -crf 20 " + quote(tmp));
  if (!png_dir.empty()) {
    std::filesystem::create_directories(png_dir);
    png = open_ffmpeg(raw + "-start_number 0 " + quote(png_dir + "/frame_%05d.png"));
  }
  std::vector<uint8_t> rgb((size_t)opt.width * opt.height * 3);
  bool ok = true;
  for (int t = 0; t < q.frames && ok; ++t) {
    r.render(q.qpos.data() + (size_t)t * m->nq, rgb.data());
    if (mp4) ok = ok && std::fwrite(rgb.data(), 1, rgb.size(), mp4) == rgb.size();
    if (png) ok = ok && std::fwrite(rgb.data(), 1, rgb.size(), png) == rgb.size();
  }
  const int rc_mp4 = mp4 ? pclose(mp4) : 0;
  const int rc_png = png ? pclose(png) : 0;
  if (!ok || rc_mp4 != 0 || rc_png != 0) {
    std::error_code ec;
    if (mp4) std::filesystem::remove(tmp, ec);
    throw Error("render_trajectory: ffmpeg failed (status " + std::to_string(rc_mp4) + "/" +
                std::to_string(rc_png) + ") writing '" + mp4_path + "' / '" + png_dir + "'");
  }
  if (mp4) std::filesystem::rename(tmp, mp4_path);
  return q.frames;
}

}  // namespace t2m::sim
