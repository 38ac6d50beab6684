// Headless Vulkan: instance, the chosen device, one queue, and the small
// helpers every pass needs (buffers, images, one-shot submission).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace holofuse::gpu {

// Vulkan failures are programmer or platform errors at this level: they
// throw with the call, the result code and the place.
#define HOLOFUSE_VK_CHECK(call)                                                \
  do {                                                                         \
    const VkResult holofuse_vk_result_ = (call);                               \
    if (holofuse_vk_result_ != VK_SUCCESS)                                     \
      ::holofuse::gpu::vkFail(#call, holofuse_vk_result_, __FILE__, __LINE__); \
  } while (0)

[[noreturn]] void vkFail(const char* call, VkResult result, const char* file, int line);

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // host-visible buffers stay mapped
};

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;  // all layers and levels (2D_ARRAY when asked for, else 2D);
                                      // none for an image only copied to and from
  VkFormat format = VK_FORMAT_UNDEFINED;
  uint32_t width = 0, height = 0, layers = 0, mip_levels = 1;
};

struct DeviceInfo {
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
};

// Set to a file, every process's Vulkan context appends each error and
// warning a layer reports (the Khronos validation layer) to it, one line
// each: `./holofuse validate` reads it, so the programs the tests start
// (the launcher's server, pods and client) are judged as well as the tests.
inline constexpr const char* kMessageLogVariable = "HOLOFUSE_VULKAN_MESSAGE_LOG";

struct ContextOptions {
  // Empty picks a discrete, then integrated GPU, then a CPU device
  // (lavapipe); a number picks that index; other text picks the first
  // device whose name contains it.
  std::string device_selector;
  // A window system's instance extensions (render_client's viewer window),
  // and VK_KHR_swapchain on the device to present to it.
  std::vector<std::string> instance_extensions;
  bool swapchain = false;
};

class VulkanContext {
 public:
  explicit VulkanContext(const std::string& device_selector = "")
      : VulkanContext(ContextOptions{device_selector, {}, false}) {}
  explicit VulkanContext(const ContextOptions& options);
  ~VulkanContext();
  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;

  static std::vector<DeviceInfo> listDevices();

  VkInstance instance() const { return instance_; }
  VkDevice device() const { return device_; }
  uint32_t queueFamily() const { return queue_family_; }
  VkPhysicalDevice physicalDevice() const { return physical_; }
  VkQueue queue() const { return queue_; }
  const std::string& deviceName() const { return device_name_; }
  // A CPU device (lavapipe): its work runs on the host's own cores.
  bool cpuDevice() const { return cpu_device_; }

  Buffer createBuffer(VkDeviceSize size, VkBufferUsageFlags usage);
  void destroy(Buffer& buffer);
  Image createImage(uint32_t width, uint32_t height, uint32_t layers, VkFormat format,
                    VkImageUsageFlags usage, VkImageAspectFlags aspect, bool array_view,
                    uint32_t mip_levels = 1);
  void destroy(Image& image);
  VkShaderModule createShader(const uint32_t* code, size_t bytes);
  // A compute pipeline of SPIR-V `code` (entry point main) on `layout`.
  VkPipeline createComputePipeline(const uint32_t* code, size_t bytes, VkPipelineLayout layout);

  // Records with fn into a fresh command buffer, submits and waits (for a
  // submission still in flight first).
  template <typename Fn>
  void submitAndWait(Fn&& fn) {
    submit(std::forward<Fn>(fn));
    waitForSubmitted();
  }
  // Records with fn and submits without waiting: the host goes on (the
  // client decodes the next frame) while the device works. Waits first for
  // the submissions in flight.
  template <typename Fn>
  void submit(Fn&& fn) {
    waitForSubmitted();
    submitBehind(std::forward<Fn>(fn));
  }
  // Records with fn and submits behind the submissions in flight, which
  // the queue finishes first: one frame in parts, with host work between
  // them (the renderer's temporal carry while the device runs the per-mesh
  // passes).
  template <typename Fn>
  void submitBehind(Fn&& fn) {
    VkCommandBuffer cmd = beginOneShot();
    fn(cmd);
    endOneShot(cmd);
  }
  // Waits for the submissions in flight, if any.
  void waitForSubmitted();
  // The submissions in flight have finished (or none is in flight).
  bool submissionDone() const;

 private:
  VkCommandBuffer beginOneShot();
  void endOneShot(VkCommandBuffer cmd);
  uint32_t memoryType(uint32_t bits, VkMemoryPropertyFlags flags) const;

  VkInstance instance_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  // Submitted, their fences not yet waited on, in submission order; and
  // fences free for the next submissions.
  struct Submission {
    VkCommandBuffer cmd;
    VkFence fence;
  };
  std::vector<Submission> in_flight_;
  std::vector<VkFence> spare_fences_;
  std::string device_name_;
  bool cpu_device_ = false;
  // The layers' messages to kMessageLogVariable's file, when it is set.
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
};

// Transfer writes (a copy into a mapped buffer) made visible to the host
// once the submission's fence has signalled.
void transferWritesToHost(VkCommandBuffer cmd);
// Compute shaders' writes (to a mapped buffer), likewise.
void shaderWritesToHost(VkCommandBuffer cmd);

// A descriptor pool for one set of `layout`, holding `sizes`, and that set
// allocated from it (the pool is the caller's to destroy, and the set
// with it).
struct DescriptorSet {
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
};
DescriptorSet createDescriptorSet(VkDevice device, VkDescriptorSetLayout layout,
                                  const std::vector<VkDescriptorPoolSize>& sizes);

// One image layout transition (all layers, mip levels first_level onwards,
// count levels) as a pipeline barrier.
void transitionImage(VkCommandBuffer cmd, const Image& image, VkImageAspectFlags aspect,
                     VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                     VkAccessFlags dst_access, VkPipelineStageFlags src_stage,
                     VkPipelineStageFlags dst_stage, uint32_t first_level = 0,
                     uint32_t level_count = VK_REMAINING_MIP_LEVELS);

}  // namespace holofuse::gpu
