// A window onto the client's pictures (render_client --window on): a
// GLFW window with a Vulkan swapchain on the renderer's own device, each
// rendered picture scaled into it. The render loop never waits on it:
// where no swapchain image is free, or the previous copy into one has not
// finished, the picture is not shown (counted as dropped), never delayed.
// Escape or Q, or the window's close button, close it; the client then
// ends as if it had rendered its frames. The user steers the view: 0 the
// orbit, 1 to 9 a pod's camera, M the next blending mode, F the next
// overlay (the cameras' weights as colours, a pod's seams, its geodesic
// distances, its visibility, none), C the overlay's next pod, P the live
// panel (fps, end to end, link, the latest frame's stages), T the next
// stylisation (sketchy stippling, none), L relighting (with a light
// probe), S a
// screenshot (of what the window shows); the left button dragged turns
// the orbit, the right one moves it, the wheel zooms.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gpu/vulkan_context.h"
#include "image/image.h"
#include "render_client/client.h"

struct GLFWwindow;

namespace holofuse::render {

// Starts GLFW and returns the instance extensions a window's surface
// needs; false, with why, where there is no display or no Vulkan surface
// support (the client then renders headless).
bool windowSystemExtensions(std::vector<std::string>* extensions, std::string* why);

class ViewerWindow {
 public:
  // A window of width x height on `context` (made with the extensions
  // above and a swapchain); null, with why, where it cannot be made.
  static std::unique_ptr<ViewerWindow> open(gpu::VulkanContext& context, uint32_t width,
                                            uint32_t height, const std::string& title,
                                            std::string* why);
  ~ViewerWindow();
  ViewerWindow(const ViewerWindow&) = delete;
  ViewerWindow& operator=(const ViewerWindow&) = delete;

  // Shows an RGBA picture scaled to the window, or drops it (see above).
  void show(const Image8& picture);
  // Takes the window's events; true once the user closed it.
  bool closed();

  // What the user asked for since the last call.
  struct Controls {
    int view_key = -1;          // 0: the orbit, 1..9: pod camera 0..8; -1: none pressed
    int mode_steps = 0;         // M pressed this many times
    bool screenshot = false;    // S pressed
    int overlay_steps = 0;      // F pressed this many times: the next overlay
    int overlay_pod_steps = 0;  // C pressed this many times: the overlay's next pod
    int panel_toggles = 0;      // P pressed this many times: the live panel shown or hidden
    int stylisation_steps = 0;  // T pressed this many times: the next stylisation
    int relight_toggles = 0;    // L pressed this many times: relighting off or on
    OrbitHold orbit;            // the mouse's hold (kept from call to call)
  };
  Controls takeControls();
  uint64_t shown() const { return shown_; }
  uint64_t dropped() const { return dropped_; }

 private:
  struct Swapchain;
  ViewerWindow(gpu::VulkanContext& context, GLFWwindow* window);
  bool makeSwapchain();
  void destroySwapchain();

  gpu::VulkanContext& context_;
  GLFWwindow* window_ = nullptr;
  std::unique_ptr<Swapchain> chain_;
  bool stale_ = false;  // out of date or resized: remade before the next picture
  Controls controls_;
  double cursor_x_ = 0, cursor_y_ = 0;
  friend struct WindowCallbacks;
  uint64_t shown_ = 0, dropped_ = 0;
};

}  // namespace holofuse::render
