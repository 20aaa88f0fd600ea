// render.h — offscreen rendering of the humanoid (MuJoCo's renderer on an EGL surfaceless OpenGL context) to
// RGB frames, PNG files and MP4 (ffmpeg).
//
// The EGL library is loaded at run time (dlopen "libEGL.so.1"), with EGL_PLATFORM=surfaceless unless the caller set
// EGL_PLATFORM; no window system or GPU is needed (Mesa's llvmpipe renders on the CPU). Scene: the model's floor,
// a free camera looking at the root body every frame (distance, elevation, azimuth in RenderOptions), shadows off by default.
// Video: raw RGB frames are piped into `ffmpeg -f rawvideo -pix_fmt rgb24 ... -c:v libx264 -pix_fmt yuv420p`,
// written to PATH.tmp.mp4 and renamed to PATH when ffmpeg succeeds. PNG frames (optional) are written by a second
// ffmpeg pipe as DIR/frame_00000.png, ... Width and height must be even (yuv420p).
// Errors: EGL / OpenGL not available, ffmpeg missing or failing, bad sizes -> t2m::Error with the reason.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/humanoid.h"
#include "sim/retarget.h"

namespace t2m::sim {

struct RenderOptions {
  int width = 640, height = 480;
  bool shadows = false;
  double distance = 3.5;     // m, camera to the tracked root
  double elevation = -12;    // degrees
  double azimuth = 120;      // degrees
};

class Renderer {
 public:
  Renderer(std::shared_ptr<const Humanoid> h, const RenderOptions& opt = {});  // throws t2m::Error
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;
  // Renders the state qpos [nq] into rgb [height * width * 3], top row first.
  void render(const double* qpos, uint8_t* rgb);
  int width() const { return opt_.width; }
  int height() const { return opt_.height; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  RenderOptions opt_;
};

// Renders every frame of q (at q.fps) to an MP4 at mp4_path (skipped when empty) and PNGs into png_dir (skipped
// when empty; created). Returns the number of frames rendered.
int render_trajectory(std::shared_ptr<const Humanoid> h, const QposTrajectory& q, const std::string& mp4_path,
                      const std::string& png_dir, const RenderOptions& opt = {});

}  // namespace t2m::sim
