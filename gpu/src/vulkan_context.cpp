#include "gpu/vulkan_context.h"

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace holofuse::gpu {

void vkFail(const char* call, VkResult result, const char* file, int line) {
  throw std::runtime_error(std::string("Vulkan call ") + call + " failed with VkResult " +
                           std::to_string(static_cast<int>(result)) + " at " + file + ":" +
                           std::to_string(line));
}

namespace {

// This executable's file name (not the name it was started by, which may
// be /proc/self/exe).
const std::string& programName() {
  static const std::string name = [] {
    char path[4096];
    const ssize_t n = readlink("/proc/self/exe", path, sizeof(path) - 1);
    if (n <= 0) return std::string(program_invocation_short_name);
    const std::string full(path, static_cast<size_t>(n));
    return full.substr(full.rfind('/') + 1);
  }();
  return name;
}

// One line per message, written with one append: lines from processes
// writing at once do not interleave (O_APPEND, one write each).
VKAPI_ATTR VkBool32 VKAPI_CALL appendMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data,
                                             void* path) {
  std::string text = std::string(data->pMessageIdName ? data->pMessageIdName : "-") + ": " +
                     (data->pMessage ? data->pMessage : "");
  std::replace(text.begin(), text.end(), '\n', ' ');
  const std::string line =
      std::string("Vulkan ") +
      (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning") + " in " +
      programName() + " (pid " + std::to_string(getpid()) + "): " + text + "\n";
  const int fd =
      open(static_cast<const char*>(path), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd >= 0) {
    [[maybe_unused]] const ssize_t written = write(fd, line.data(), line.size());
    close(fd);
  }
  return VK_FALSE;
}

VkDebugUtilsMessengerCreateInfoEXT messengerInfo(const std::string& path) {
  VkDebugUtilsMessengerCreateInfoEXT info{};
  info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
  info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  // Not the general ones: the loader says there which layers it added.
  info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  info.pfnUserCallback = appendMessage;
  info.pUserData = const_cast<char*>(path.c_str());
  return info;
}

// The message log's path, checked writable: a log that cannot be written
// would pass every message silently.
const std::string& checkedMessageLog() {
  static const std::string path = [] {
    const char* variable = std::getenv(kMessageLogVariable);
    const std::string p = variable ? variable : "";
    if (p.empty()) return p;
    const int fd = open(p.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
      throw std::runtime_error(std::string(kMessageLogVariable) + "=" + p +
                               ": cannot append to it (" + std::strerror(errno) + ")");
    close(fd);
    return p;
  }();
  return path;
}

VkInstance createInstance(const std::vector<std::string>& extensions = {}) {
  std::vector<const char*> names;
  for (const std::string& e : extensions) names.push_back(e.c_str());
  const std::string& log = checkedMessageLog();
  // The chained messenger also hears instance creation and destruction.
  VkDebugUtilsMessengerCreateInfoEXT messenger = messengerInfo(log);
  if (!log.empty()) names.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "holofuse";
  app.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  info.pNext = log.empty() ? nullptr : &messenger;
  info.pApplicationInfo = &app;
  info.enabledExtensionCount = static_cast<uint32_t>(names.size());
  info.ppEnabledExtensionNames = names.data();
  VkInstance instance = VK_NULL_HANDLE;
  HOLOFUSE_VK_CHECK(vkCreateInstance(&info, nullptr, &instance));
  return instance;
}

VkDebugUtilsMessengerEXT createMessenger(VkInstance instance) {
  const std::string& log = checkedMessageLog();
  if (log.empty()) return VK_NULL_HANDLE;
  auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
      vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
  const VkDebugUtilsMessengerCreateInfoEXT info = messengerInfo(log);
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  HOLOFUSE_VK_CHECK(create(instance, &info, nullptr, &messenger));
  return messenger;
}

void destroyInstance(VkInstance instance, VkDebugUtilsMessengerEXT messenger) {
  if (messenger != VK_NULL_HANDLE) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    destroy(instance, messenger, nullptr);
  }
  vkDestroyInstance(instance, nullptr);
}

std::vector<VkPhysicalDevice> physicalDevices(VkInstance instance) {
  uint32_t count = 0;
  HOLOFUSE_VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
  std::vector<VkPhysicalDevice> devices(count);
  HOLOFUSE_VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, devices.data()));
  return devices;
}

int typeRank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 3;
    default:
      return 4;
  }
}

}  // namespace

std::vector<DeviceInfo> VulkanContext::listDevices() {
  VkInstance instance = createInstance();
  std::vector<DeviceInfo> infos;
  for (VkPhysicalDevice d : physicalDevices(instance)) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(d, &props);
    infos.push_back({props.deviceName, props.deviceType});
  }
  vkDestroyInstance(instance, nullptr);
  return infos;
}

VulkanContext::VulkanContext(const ContextOptions& options) {
  const std::string& selector = options.device_selector;
  instance_ = createInstance(options.instance_extensions);
  messenger_ = createMessenger(instance_);
  const auto devices = physicalDevices(instance_);
  if (devices.empty())
    throw std::runtime_error("no Vulkan device (install mesa-vulkan-drivers for lavapipe)");
  int best = -1;
  for (size_t i = 0; i < devices.size(); ++i) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(devices[i], &props);
    bool match;
    if (selector.empty()) {
      VkPhysicalDeviceProperties best_props{};
      if (best >= 0) vkGetPhysicalDeviceProperties(devices[best], &best_props);
      match = best < 0 || typeRank(props.deviceType) < typeRank(best_props.deviceType);
    } else if (selector.find_first_not_of("0123456789") == std::string::npos) {
      match = std::to_string(i) == selector;
    } else {
      match = best < 0 && std::string(props.deviceName).find(selector) != std::string::npos;
    }
    if (match) best = static_cast<int>(i);
  }
  if (best < 0) {
    std::string names;
    for (size_t i = 0; i < devices.size(); ++i) {
      VkPhysicalDeviceProperties props;
      vkGetPhysicalDeviceProperties(devices[i], &props);
      names += "\n  " + std::to_string(i) + ": " + props.deviceName;
    }
    destroyInstance(instance_, messenger_);
    throw std::runtime_error("no Vulkan device matches '" + selector + "'; devices:" + names);
  }
  physical_ = devices[best];
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physical_, &props);
  device_name_ = props.deviceName;
  cpu_device_ = props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;

  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &family_count, families.data());
  queue_family_ = UINT32_MAX;
  for (uint32_t i = 0; i < family_count; ++i) {
    if ((families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) &&
        (families[i].queueFlags & VK_QUEUE_COMPUTE_BIT)) {
      queue_family_ = i;
      break;
    }
  }
  if (queue_family_ == UINT32_MAX)
    throw std::runtime_error(device_name_ + " has no graphics+compute queue");
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{};
  queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queue_info.queueFamilyIndex = queue_family_;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  VkDeviceCreateInfo device_info{};
  device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  const char* swapchain = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
  if (options.swapchain) {
    device_info.enabledExtensionCount = 1;
    device_info.ppEnabledExtensionNames = &swapchain;
  }
  HOLOFUSE_VK_CHECK(vkCreateDevice(physical_, &device_info, nullptr, &device_));
  vkGetDeviceQueue(device_, queue_family_, 0, &queue_);

  VkCommandPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool_info.flags =
      VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT | VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pool_info.queueFamilyIndex = queue_family_;
  HOLOFUSE_VK_CHECK(vkCreateCommandPool(device_, &pool_info, nullptr, &pool_));
}

VulkanContext::~VulkanContext() {
  if (device_ != VK_NULL_HANDLE) {
    // Not waitForSubmitted: its checks throw, and a destructor must not.
    vkDeviceWaitIdle(device_);
    for (const Submission& s : in_flight_) {
      vkFreeCommandBuffers(device_, pool_, 1, &s.cmd);
      vkDestroyFence(device_, s.fence, nullptr);
    }
    for (VkFence fence : spare_fences_) vkDestroyFence(device_, fence, nullptr);
    vkDestroyCommandPool(device_, pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (instance_ != VK_NULL_HANDLE) destroyInstance(instance_, messenger_);
}

uint32_t VulkanContext::memoryType(uint32_t bits, VkMemoryPropertyFlags flags) const {
  VkPhysicalDeviceMemoryProperties props;
  vkGetPhysicalDeviceMemoryProperties(physical_, &props);
  for (uint32_t i = 0; i < props.memoryTypeCount; ++i) {
    if ((bits & (1u << i)) && (props.memoryTypes[i].propertyFlags & flags) == flags) return i;
  }
  throw std::runtime_error("no Vulkan memory type with the needed properties");
}

Buffer VulkanContext::createBuffer(VkDeviceSize size, VkBufferUsageFlags usage) {
  Buffer b;
  b.size = size;
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = size;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  HOLOFUSE_VK_CHECK(vkCreateBuffer(device_, &info, nullptr, &b.buffer));
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device_, b.buffer, &req);
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                                             VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  HOLOFUSE_VK_CHECK(vkAllocateMemory(device_, &alloc, nullptr, &b.memory));
  HOLOFUSE_VK_CHECK(vkBindBufferMemory(device_, b.buffer, b.memory, 0));
  HOLOFUSE_VK_CHECK(vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped));
  return b;
}

void VulkanContext::destroy(Buffer& b) {
  if (b.buffer == VK_NULL_HANDLE) return;
  vkUnmapMemory(device_, b.memory);
  vkDestroyBuffer(device_, b.buffer, nullptr);
  vkFreeMemory(device_, b.memory, nullptr);
  b = Buffer{};
}

Image VulkanContext::createImage(uint32_t width, uint32_t height, uint32_t layers, VkFormat format,
                                 VkImageUsageFlags usage, VkImageAspectFlags aspect,
                                 bool array_view, uint32_t mip_levels) {
  Image img;
  img.format = format;
  img.width = width;
  img.height = height;
  img.layers = layers;
  img.mip_levels = mip_levels;
  VkImageCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = mip_levels;
  info.arrayLayers = layers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  HOLOFUSE_VK_CHECK(vkCreateImage(device_, &info, nullptr, &img.image));
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(device_, img.image, &req);
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  HOLOFUSE_VK_CHECK(vkAllocateMemory(device_, &alloc, nullptr, &img.memory));
  HOLOFUSE_VK_CHECK(vkBindImageMemory(device_, img.image, img.memory, 0));
  auto makeView = [&](VkImageViewType type, uint32_t first, uint32_t count) {
    VkImageViewCreateInfo v{};
    v.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    v.image = img.image;
    v.viewType = type;
    v.format = format;
    v.subresourceRange = {aspect, 0, mip_levels, first, count};
    VkImageView view;
    HOLOFUSE_VK_CHECK(vkCreateImageView(device_, &v, nullptr, &view));
    return view;
  };
  // An image only copied to and from (the viewer's picture) has no view:
  // a view needs a usage that reads or writes through one.
  const VkImageUsageFlags viewed = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                   VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                                   VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT;
  if (usage & viewed)
    img.view =
        makeView(array_view ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D, 0, layers);
  return img;
}

void VulkanContext::destroy(Image& img) {
  if (img.image == VK_NULL_HANDLE) return;
  vkDestroyImageView(device_, img.view, nullptr);
  vkDestroyImage(device_, img.image, nullptr);
  vkFreeMemory(device_, img.memory, nullptr);
  img = Image{};
}

VkShaderModule VulkanContext::createShader(const uint32_t* code, size_t bytes) {
  VkShaderModuleCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  info.codeSize = bytes;
  info.pCode = code;
  VkShaderModule module;
  HOLOFUSE_VK_CHECK(vkCreateShaderModule(device_, &info, nullptr, &module));
  return module;
}

VkPipeline VulkanContext::createComputePipeline(const uint32_t* code, size_t bytes,
                                                VkPipelineLayout layout) {
  VkShaderModule module = createShader(code, bytes);
  VkComputePipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module;
  info.stage.pName = "main";
  info.layout = layout;
  VkPipeline pipeline;
  const VkResult result =
      vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline);
  vkDestroyShaderModule(device_, module, nullptr);
  if (result != VK_SUCCESS) vkFail("vkCreateComputePipelines", result, __FILE__, __LINE__);
  return pipeline;
}

VkCommandBuffer VulkanContext::beginOneShot() {
  VkCommandBufferAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  alloc.commandPool = pool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VkCommandBuffer cmd;
  HOLOFUSE_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, &cmd));
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  HOLOFUSE_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
  return cmd;
}

void VulkanContext::endOneShot(VkCommandBuffer cmd) {
  HOLOFUSE_VK_CHECK(vkEndCommandBuffer(cmd));
  VkSubmitInfo submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  VkFence fence = VK_NULL_HANDLE;
  if (spare_fences_.empty()) {
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    HOLOFUSE_VK_CHECK(vkCreateFence(device_, &fence_info, nullptr, &fence));
  } else {
    fence = spare_fences_.back();
    spare_fences_.pop_back();
  }
  HOLOFUSE_VK_CHECK(vkQueueSubmit(queue_, 1, &submit, fence));
  in_flight_.push_back({cmd, fence});
}

bool VulkanContext::submissionDone() const {
  // A fence's signal covers every command submitted to the queue before
  // it: the last one done, all are.
  return in_flight_.empty() || vkGetFenceStatus(device_, in_flight_.back().fence) == VK_SUCCESS;
}

void VulkanContext::waitForSubmitted() {
  if (in_flight_.empty()) return;
  std::vector<VkFence> fences;
  for (const Submission& s : in_flight_) fences.push_back(s.fence);
  HOLOFUSE_VK_CHECK(vkWaitForFences(device_, static_cast<uint32_t>(fences.size()), fences.data(),
                                    VK_TRUE, UINT64_MAX));
  HOLOFUSE_VK_CHECK(vkResetFences(device_, static_cast<uint32_t>(fences.size()), fences.data()));
  for (const Submission& s : in_flight_) vkFreeCommandBuffers(device_, pool_, 1, &s.cmd);
  spare_fences_.insert(spare_fences_.end(), fences.begin(), fences.end());
  in_flight_.clear();
}

namespace {

void writesToHost(VkCommandBuffer cmd, VkAccessFlags access, VkPipelineStageFlags stage) {
  VkMemoryBarrier to_host{};
  to_host.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  to_host.srcAccessMask = access;
  to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(cmd, stage, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &to_host, 0, nullptr, 0,
                       nullptr);
}

}  // namespace

void transferWritesToHost(VkCommandBuffer cmd) {
  writesToHost(cmd, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
}

void shaderWritesToHost(VkCommandBuffer cmd) {
  writesToHost(cmd, VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
}

DescriptorSet createDescriptorSet(VkDevice device, VkDescriptorSetLayout layout,
                                  const std::vector<VkDescriptorPoolSize>& sizes) {
  DescriptorSet out;
  VkDescriptorPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pool_info.maxSets = 1;
  pool_info.poolSizeCount = static_cast<uint32_t>(sizes.size());
  pool_info.pPoolSizes = sizes.data();
  HOLOFUSE_VK_CHECK(vkCreateDescriptorPool(device, &pool_info, nullptr, &out.pool));
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = out.pool;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &layout;
  HOLOFUSE_VK_CHECK(vkAllocateDescriptorSets(device, &alloc, &out.set));
  return out;
}

void transitionImage(VkCommandBuffer cmd, const Image& image, VkImageAspectFlags aspect,
                     VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                     VkAccessFlags dst_access, VkPipelineStageFlags src_stage,
                     VkPipelineStageFlags dst_stage, uint32_t first_level, uint32_t level_count) {
  VkImageMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
  barrier.oldLayout = from;
  barrier.newLayout = to;
  barrier.srcAccessMask = src_access;
  barrier.dstAccessMask = dst_access;
  barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.image = image.image;
  barrier.subresourceRange = {aspect, first_level, level_count, 0, image.layers};
  vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

}  // namespace holofuse::gpu
