#include "render_client/viewer_window.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

namespace holofuse::render {
namespace {

// GLFW reports errors through a callback: the last one, for the line the
// client prints.
std::string& lastGlfwError() {
  static std::string error;
  return error;
}

void onGlfwError(int, const char* description) { lastGlfwError() = description; }

// Fits a picture of w x h into the window, centred, aspect kept.
VkImageBlit fitted(uint32_t w, uint32_t h, VkExtent2D window) {
  const double scale =
      std::min(static_cast<double>(window.width) / w, static_cast<double>(window.height) / h);
  const int32_t fit_w = std::max(1, static_cast<int32_t>(w * scale)),
                fit_h = std::max(1, static_cast<int32_t>(h * scale));
  const int32_t x0 = (static_cast<int32_t>(window.width) - fit_w) / 2,
                y0 = (static_cast<int32_t>(window.height) - fit_h) / 2;
  VkImageBlit blit{};
  blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  blit.srcOffsets[1] = {static_cast<int32_t>(w), static_cast<int32_t>(h), 1};
  blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  blit.dstOffsets[0] = {x0, y0, 0};
  blit.dstOffsets[1] = {x0 + fit_w, y0 + fit_h, 1};
  return blit;
}

}  // namespace

// GLFW's callbacks, which reach the window through its user pointer.
struct WindowCallbacks {
  static ViewerWindow& of(GLFWwindow* window) {
    return *static_cast<ViewerWindow*>(glfwGetWindowUserPointer(window));
  }
  static void key(GLFWwindow* window, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    ViewerWindow::Controls& c = of(window).controls_;
    if (key == GLFW_KEY_ESCAPE || key == GLFW_KEY_Q) glfwSetWindowShouldClose(window, GLFW_TRUE);
    if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) c.view_key = key - GLFW_KEY_0;
    if (key == GLFW_KEY_M) ++c.mode_steps;
    if (key == GLFW_KEY_S) c.screenshot = true;
    if (key == GLFW_KEY_F) ++c.overlay_steps;
    if (key == GLFW_KEY_C) ++c.overlay_pod_steps;
    if (key == GLFW_KEY_P) ++c.panel_toggles;
    if (key == GLFW_KEY_T) ++c.stylisation_steps;
    if (key == GLFW_KEY_L) ++c.relight_toggles;
  }
  static void cursor(GLFWwindow* window, double x, double y) {
    ViewerWindow& viewer = of(window);
    const double dx = x - viewer.cursor_x_, dy = y - viewer.cursor_y_;
    viewer.cursor_x_ = x;
    viewer.cursor_y_ = y;
    int w = 0, h = 0;
    glfwGetWindowSize(window, &w, &h);
    OrbitHold& orbit = viewer.controls_.orbit;
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
      orbit.held = true;
      orbit.yaw -= 180.0 * dx / std::max(w, 1);  // a window's width: half a turn
      orbit.pitch += 90.0 * dy / std::max(h, 1);
    } else if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
      orbit.held = true;
      orbit.pan_right -= dx / std::max(w, 1);
      orbit.pan_up += dy / std::max(h, 1);
    }
  }
  static void scroll(GLFWwindow* window, double, double y) {
    OrbitHold& orbit = of(window).controls_.orbit;
    orbit.held = true;
    orbit.zoom *= std::pow(0.9, y);
  }
};

struct ViewerWindow::Swapchain {
  VkSurfaceKHR surface = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain = VK_NULL_HANDLE;
  VkExtent2D extent{};
  std::vector<VkImage> images;
  std::vector<VkSemaphore> presentable;  // per image: its copy is done
  // Two pictures in flight at most: each slot's copy, its fence and the
  // semaphore its acquire signals.
  struct Slot {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore acquired = VK_NULL_HANDLE;
    // The picture's bytes and image (the last picture's size, RGBA8), the
    // slot's own: the other slot's copy may still read its own while this
    // one is written.
    gpu::Buffer staging;
    gpu::Image picture;
  };
  std::array<Slot, 2> slots{};
  size_t next_slot = 0;
  VkCommandPool pool = VK_NULL_HANDLE;
};

bool windowSystemExtensions(std::vector<std::string>* extensions, std::string* why) {
  glfwSetErrorCallback(onGlfwError);
  if (glfwInit() != GLFW_TRUE) {
    *why = "no display (" + lastGlfwError() + ")";
    return false;
  }
  if (glfwVulkanSupported() != GLFW_TRUE) {
    *why = "no Vulkan surface support (" + lastGlfwError() + ")";
    glfwTerminate();
    return false;
  }
  uint32_t count = 0;
  const char** names = glfwGetRequiredInstanceExtensions(&count);
  extensions->assign(names, names + count);
  return true;
}

std::unique_ptr<ViewerWindow> ViewerWindow::open(gpu::VulkanContext& context, uint32_t width,
                                                 uint32_t height, const std::string& title,
                                                 std::string* why) {
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  GLFWwindow* window = glfwCreateWindow(static_cast<int>(width), static_cast<int>(height),
                                        title.c_str(), nullptr, nullptr);
  if (window == nullptr) {
    *why = "no window (" + lastGlfwError() + ")";
    return nullptr;
  }
  std::unique_ptr<ViewerWindow> viewer(new ViewerWindow(context, window));
  Swapchain& chain = *viewer->chain_;
  if (glfwCreateWindowSurface(context.instance(), window, nullptr, &chain.surface) != VK_SUCCESS) {
    *why = "no Vulkan surface for the window (" + lastGlfwError() + ")";
    return nullptr;
  }
  VkBool32 presents = VK_FALSE;
  vkGetPhysicalDeviceSurfaceSupportKHR(context.physicalDevice(), context.queueFamily(),
                                       chain.surface, &presents);
  if (!presents) {
    *why = context.deviceName() + "'s queue cannot present to the window";
    return nullptr;
  }
  glfwSetWindowUserPointer(window, viewer.get());
  glfwSetKeyCallback(window, WindowCallbacks::key);
  glfwSetCursorPosCallback(window, WindowCallbacks::cursor);
  glfwSetScrollCallback(window, WindowCallbacks::scroll);
  VkDevice d = context.device();
  VkCommandPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = context.queueFamily();
  HOLOFUSE_VK_CHECK(vkCreateCommandPool(d, &pool_info, nullptr, &chain.pool));
  for (auto& slot : chain.slots) {
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = chain.pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    HOLOFUSE_VK_CHECK(vkAllocateCommandBuffers(d, &alloc, &slot.cmd));
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    fence_info.flags = VK_FENCE_CREATE_SIGNALED_BIT;
    HOLOFUSE_VK_CHECK(vkCreateFence(d, &fence_info, nullptr, &slot.fence));
    VkSemaphoreCreateInfo semaphore_info{};
    semaphore_info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    HOLOFUSE_VK_CHECK(vkCreateSemaphore(d, &semaphore_info, nullptr, &slot.acquired));
  }
  if (!viewer->makeSwapchain()) {
    *why = "no swapchain the pictures can be copied into";
    return nullptr;
  }
  return viewer;
}

ViewerWindow::ViewerWindow(gpu::VulkanContext& context, GLFWwindow* window)
    : context_(context), window_(window), chain_(std::make_unique<Swapchain>()) {}

ViewerWindow::~ViewerWindow() {
  VkDevice d = context_.device();
  vkDeviceWaitIdle(d);
  destroySwapchain();
  for (auto& slot : chain_->slots) {
    if (slot.fence != VK_NULL_HANDLE) vkDestroyFence(d, slot.fence, nullptr);
    if (slot.acquired != VK_NULL_HANDLE) vkDestroySemaphore(d, slot.acquired, nullptr);
    context_.destroy(slot.staging);
    context_.destroy(slot.picture);
  }
  if (chain_->pool != VK_NULL_HANDLE) vkDestroyCommandPool(d, chain_->pool, nullptr);
  if (chain_->surface != VK_NULL_HANDLE)
    vkDestroySurfaceKHR(context_.instance(), chain_->surface, nullptr);
  glfwDestroyWindow(window_);
  glfwTerminate();
}

void ViewerWindow::destroySwapchain() {
  VkDevice d = context_.device();
  if (chain_->swapchain == VK_NULL_HANDLE) return;
  // A remade swapchain (a resize) waits for what uses the old one: rare,
  // unlike a picture, which never waits.
  vkDeviceWaitIdle(d);
  for (VkSemaphore s : chain_->presentable) vkDestroySemaphore(d, s, nullptr);
  chain_->presentable.clear();
  vkDestroySwapchainKHR(d, chain_->swapchain, nullptr);
  chain_->swapchain = VK_NULL_HANDLE;
  chain_->images.clear();
}

bool ViewerWindow::makeSwapchain() {
  destroySwapchain();
  stale_ = false;
  VkPhysicalDevice physical = context_.physicalDevice();
  VkDevice d = context_.device();
  Swapchain& chain = *chain_;
  VkSurfaceCapabilitiesKHR caps;
  HOLOFUSE_VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(physical, chain.surface, &caps));
  if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) return false;
  int fb_w = 0, fb_h = 0;
  glfwGetFramebufferSize(window_, &fb_w, &fb_h);
  chain.extent = caps.currentExtent.width != UINT32_MAX
                     ? caps.currentExtent
                     : VkExtent2D{static_cast<uint32_t>(fb_w), static_cast<uint32_t>(fb_h)};
  if (chain.extent.width == 0 || chain.extent.height == 0) return false;  // minimised
  uint32_t count = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(physical, chain.surface, &count, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(count);
  vkGetPhysicalDeviceSurfaceFormatsKHR(physical, chain.surface, &count, formats.data());
  // A format the picture can be blitted (scaled, converted) into.
  const VkSurfaceFormatKHR* chosen = nullptr;
  for (const auto& f : formats) {
    VkFormatProperties props;
    vkGetPhysicalDeviceFormatProperties(physical, f.format, &props);
    if (!(props.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT)) continue;
    if (chosen == nullptr || f.format == VK_FORMAT_B8G8R8A8_UNORM) chosen = &f;
  }
  if (chosen == nullptr) return false;
  vkGetPhysicalDeviceSurfacePresentModesKHR(physical, chain.surface, &count, nullptr);
  std::vector<VkPresentModeKHR> modes(count);
  vkGetPhysicalDeviceSurfacePresentModesKHR(physical, chain.surface, &count, modes.data());
  // Never waiting on the display: mailbox, else immediate, else FIFO
  // (whose waits the zero-timeout acquire turns into dropped pictures).
  VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;
  for (VkPresentModeKHR m : {VK_PRESENT_MODE_IMMEDIATE_KHR, VK_PRESENT_MODE_MAILBOX_KHR}) {
    if (std::find(modes.begin(), modes.end(), m) != modes.end()) mode = m;
  }
  VkSwapchainCreateInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
  info.surface = chain.surface;
  info.minImageCount = caps.maxImageCount == 0
                           ? caps.minImageCount + 1
                           : std::min(caps.minImageCount + 1, caps.maxImageCount);
  info.imageFormat = chosen->format;
  info.imageColorSpace = chosen->colorSpace;
  info.imageExtent = chain.extent;
  info.imageArrayLayers = 1;
  info.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.preTransform = caps.currentTransform;
  info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  info.presentMode = mode;
  info.clipped = VK_TRUE;
  HOLOFUSE_VK_CHECK(vkCreateSwapchainKHR(d, &info, nullptr, &chain.swapchain));
  vkGetSwapchainImagesKHR(d, chain.swapchain, &count, nullptr);
  chain.images.resize(count);
  vkGetSwapchainImagesKHR(d, chain.swapchain, &count, chain.images.data());
  for (uint32_t i = 0; i < count; ++i) {
    VkSemaphoreCreateInfo semaphore_info{};
    semaphore_info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    VkSemaphore s;
    HOLOFUSE_VK_CHECK(vkCreateSemaphore(d, &semaphore_info, nullptr, &s));
    chain.presentable.push_back(s);
  }
  return true;
}

ViewerWindow::Controls ViewerWindow::takeControls() {
  Controls taken = controls_;
  controls_.view_key = -1;
  controls_.mode_steps = 0;
  controls_.screenshot = false;
  controls_.overlay_steps = 0;
  controls_.overlay_pod_steps = 0;
  controls_.panel_toggles = 0;
  controls_.stylisation_steps = 0;
  controls_.relight_toggles = 0;
  return taken;
}

bool ViewerWindow::closed() {
  glfwPollEvents();
  return glfwWindowShouldClose(window_) == GLFW_TRUE;
}

void ViewerWindow::show(const Image8& picture) {
  Swapchain& chain = *chain_;
  VkDevice d = context_.device();
  int fb_w = 0, fb_h = 0;
  glfwGetFramebufferSize(window_, &fb_w, &fb_h);
  const bool resized =
      chain.swapchain != VK_NULL_HANDLE && (static_cast<uint32_t>(fb_w) != chain.extent.width ||
                                            static_cast<uint32_t>(fb_h) != chain.extent.height);
  if (fb_w == 0 || fb_h == 0 || picture.width == 0 || picture.channels < 3 ||
      ((stale_ || resized || chain.swapchain == VK_NULL_HANDLE) && !makeSwapchain())) {
    ++dropped_;  // minimised, or no swapchain for now
    return;
  }
  Swapchain::Slot& slot = chain.slots[chain.next_slot];
  if (vkGetFenceStatus(d, slot.fence) != VK_SUCCESS) {
    ++dropped_;  // the copy before is still running
    return;
  }
  uint32_t index = 0;
  const VkResult acquired =
      vkAcquireNextImageKHR(d, chain.swapchain, 0, slot.acquired, VK_NULL_HANDLE, &index);
  if (acquired == VK_TIMEOUT || acquired == VK_NOT_READY || acquired == VK_ERROR_OUT_OF_DATE_KHR) {
    stale_ = acquired == VK_ERROR_OUT_OF_DATE_KHR;
    ++dropped_;
    return;
  }
  if (acquired == VK_SUBOPTIMAL_KHR) {
    stale_ = true;  // shown this time, remade for the next
  } else if (acquired != VK_SUCCESS) {
    gpu::vkFail("vkAcquireNextImageKHR", acquired, __FILE__, __LINE__);
  }
  // The picture, as RGBA8, into the staging buffer and its image.
  const VkDeviceSize bytes = VkDeviceSize{4} * picture.width * picture.height;
  if (slot.staging.size < bytes) {
    context_.destroy(slot.staging);
    slot.staging = context_.createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  }
  if (slot.picture.width != picture.width || slot.picture.height != picture.height) {
    context_.destroy(slot.picture);
    slot.picture =
        context_.createImage(picture.width, picture.height, 1, VK_FORMAT_R8G8B8A8_UNORM,
                             VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT, false);
  }
  auto* out = static_cast<uint8_t*>(slot.staging.mapped);
  if (picture.channels == 4) {
    std::memcpy(out, picture.pixels.data(), bytes);
  } else {
    for (size_t i = 0; i < static_cast<size_t>(picture.width) * picture.height; ++i) {
      std::memcpy(out + 4 * i, picture.pixels.data() + picture.channels * i, 3);
      out[4 * i + 3] = 255;
    }
  }
  HOLOFUSE_VK_CHECK(vkResetFences(d, 1, &slot.fence));
  HOLOFUSE_VK_CHECK(vkResetCommandBuffer(slot.cmd, 0));
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  HOLOFUSE_VK_CHECK(vkBeginCommandBuffer(slot.cmd, &begin));
  const VkPipelineStageFlags transfer = VK_PIPELINE_STAGE_TRANSFER_BIT;
  gpu::transitionImage(slot.cmd, slot.picture, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, transfer);
  VkBufferImageCopy copy{};
  copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  copy.imageExtent = {picture.width, picture.height, 1};
  vkCmdCopyBufferToImage(slot.cmd, slot.staging.buffer, slot.picture.image,
                         VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
  gpu::transitionImage(slot.cmd, slot.picture, VK_IMAGE_ASPECT_COLOR_BIT,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                       VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT, transfer,
                       transfer);
  gpu::Image target;
  target.image = chain.images[index];
  target.layers = 1;
  gpu::transitionImage(slot.cmd, target, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                       transfer, transfer);
  const VkClearColorValue black{{0.0f, 0.0f, 0.0f, 1.0f}};
  const VkImageSubresourceRange whole{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdClearColorImage(slot.cmd, target.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &black, 1,
                       &whole);
  VkMemoryBarrier cleared{};
  cleared.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  cleared.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  cleared.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  vkCmdPipelineBarrier(slot.cmd, transfer, transfer, 0, 1, &cleared, 0, nullptr, 0, nullptr);
  const VkImageBlit blit = fitted(picture.width, picture.height, chain.extent);
  vkCmdBlitImage(slot.cmd, slot.picture.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target.image,
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
  gpu::transitionImage(slot.cmd, target, VK_IMAGE_ASPECT_COLOR_BIT,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                       VK_ACCESS_TRANSFER_WRITE_BIT, 0, transfer,
                       VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
  HOLOFUSE_VK_CHECK(vkEndCommandBuffer(slot.cmd));
  VkSubmitInfo submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  submit.waitSemaphoreCount = 1;
  submit.pWaitSemaphores = &slot.acquired;
  submit.pWaitDstStageMask = &transfer;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &slot.cmd;
  submit.signalSemaphoreCount = 1;
  submit.pSignalSemaphores = &chain.presentable[index];
  HOLOFUSE_VK_CHECK(vkQueueSubmit(context_.queue(), 1, &submit, slot.fence));
  VkPresentInfoKHR present{};
  present.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
  present.waitSemaphoreCount = 1;
  present.pWaitSemaphores = &chain.presentable[index];
  present.swapchainCount = 1;
  present.pSwapchains = &chain.swapchain;
  present.pImageIndices = &index;
  const VkResult presented = vkQueuePresentKHR(context_.queue(), &present);
  if (presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR) {
    stale_ = true;
  } else if (presented != VK_SUCCESS) {
    gpu::vkFail("vkQueuePresentKHR", presented, __FILE__, __LINE__);
  }
  chain.next_slot = 1 - chain.next_slot;
  ++shown_;
}

}  // namespace holofuse::render
