// Kernels (compute pipelines from the SPIR-V embedded at build time) and sequences of
// dispatches in one command buffer.
#include <fmt/format.h>

#include <algorithm>
#include <cstring>

#include "photosite/gpu/kernel.h"
#include "photosite/gpu/sequence.h"
#include "spirv.h"
#include "vk.h"

namespace photosite::gpu {

struct Kernel::Impl {
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
};

Kernel::Kernel(Context& ctx, const std::string& name, int buffers, uint32_t push_bytes)
    : ctx_(ctx), name_(name), buffers_(buffers), push_bytes_(push_bytes), impl_(std::make_unique<Impl>()) {
  const Spirv spv = find_spirv(name);
  auto& C = ctx.impl();
  auto& f = C.f;
  VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = spv.words * 4;
  smci.pCode = spv.code;
  vk::check(f.vkCreateShaderModule(C.device, &smci, nullptr, &impl_->module), "creating a shader module");
  std::vector<VkDescriptorSetLayoutBinding> b(buffers);
  for (int i = 0; i < buffers; ++i) {
    b[i] = {};
    b[i].binding = static_cast<uint32_t>(i);
    b[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    b[i].descriptorCount = 1;
    b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo dl{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dl.bindingCount = static_cast<uint32_t>(buffers);
  dl.pBindings = b.data();
  vk::check(f.vkCreateDescriptorSetLayout(C.device, &dl, nullptr, &impl_->set_layout), "creating a descriptor set layout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
  VkPipelineLayoutCreateInfo pl{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pl.setLayoutCount = 1;
  pl.pSetLayouts = &impl_->set_layout;
  pl.pushConstantRangeCount = push_bytes ? 1 : 0;
  pl.pPushConstantRanges = &range;
  vk::check(f.vkCreatePipelineLayout(C.device, &pl, nullptr, &impl_->layout), "creating a pipeline layout");
  VkComputePipelineCreateInfo cp{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cp.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  cp.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  cp.stage.module = impl_->module;
  cp.stage.pName = "main";
  cp.layout = impl_->layout;
  vk::check(f.vkCreateComputePipelines(C.device, VK_NULL_HANDLE, 1, &cp, nullptr, &impl_->pipeline),
            ("creating the pipeline of kernel " + name).c_str());
}

Kernel::~Kernel() {
  auto& C = ctx_.impl();
  auto& f = C.f;
  f.vkDestroyPipeline(C.device, impl_->pipeline, nullptr);
  f.vkDestroyPipelineLayout(C.device, impl_->layout, nullptr);
  f.vkDestroyDescriptorSetLayout(C.device, impl_->set_layout, nullptr);
  f.vkDestroyShaderModule(C.device, impl_->module, nullptr);
}

// ---- sequences ---------------------------------------------------------------------------
namespace {
constexpr uint32_t kMaxDispatches = 64, kMaxBuffersPerDispatch = 16;
}

struct Sequence::Impl {
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkDescriptorPool descriptors = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;
  std::vector<std::string> labels;
  std::vector<double> ms;
  bool recording = false;
};

Sequence::Sequence(Context& ctx) : ctx_(ctx), impl_(std::make_unique<Impl>()) {
  auto& C = ctx.impl();
  auto& f = C.f;
  VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpi.queueFamilyIndex = C.queue_family;
  vk::check(f.vkCreateCommandPool(C.device, &cpi, nullptr, &impl_->pool), "creating a command pool");
  VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cai.commandPool = impl_->pool;
  cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cai.commandBufferCount = 1;
  vk::check(f.vkAllocateCommandBuffers(C.device, &cai, &impl_->cmd), "allocating a command buffer");
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kMaxDispatches * kMaxBuffersPerDispatch};
  VkDescriptorPoolCreateInfo dpi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpi.maxSets = kMaxDispatches;
  dpi.poolSizeCount = 1;
  dpi.pPoolSizes = &size;
  vk::check(f.vkCreateDescriptorPool(C.device, &dpi, nullptr, &impl_->descriptors), "creating a descriptor pool");
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  vk::check(f.vkCreateFence(C.device, &fci, nullptr, &impl_->fence), "creating a fence");
  if (ctx.device().timestamps) {
    VkQueryPoolCreateInfo q{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_TIMESTAMP;
    q.queryCount = kMaxDispatches + 1;
    vk::check(f.vkCreateQueryPool(C.device, &q, nullptr, &impl_->queries), "creating a timestamp query pool");
  }
}

Sequence::~Sequence() {
  auto& C = ctx_.impl();
  auto& f = C.f;
  if (impl_->queries) f.vkDestroyQueryPool(C.device, impl_->queries, nullptr);
  f.vkDestroyFence(C.device, impl_->fence, nullptr);
  f.vkDestroyDescriptorPool(C.device, impl_->descriptors, nullptr);
  f.vkDestroyCommandPool(C.device, impl_->pool, nullptr);
}

void Sequence::begin() {
  auto& C = ctx_.impl();
  auto& f = C.f;
  vk::check(f.vkResetCommandBuffer(impl_->cmd, 0), "resetting a command buffer");
  vk::check(f.vkResetDescriptorPool(C.device, impl_->descriptors, 0), "resetting a descriptor pool");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vk::check(f.vkBeginCommandBuffer(impl_->cmd, &bi), "beginning a command buffer");
  impl_->labels.clear();
  impl_->ms.clear();
  impl_->recording = true;
  if (impl_->queries) {
    f.vkCmdResetQueryPool(impl_->cmd, impl_->queries, 0, kMaxDispatches + 1);
    f.vkCmdWriteTimestamp(impl_->cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, impl_->queries, 0);
  }
}

void Sequence::dispatch(const Kernel& k, std::initializer_list<Buffer*> buffers, const void* params,
                        uint32_t gx, uint32_t gy, uint32_t gz, const std::string& label) {
  if (!impl_->recording) begin();
  if (static_cast<int>(buffers.size()) != k.buffers())
    internal_error(fmt::format("gpu: kernel {} takes {} buffers, given {}", k.name(), k.buffers(), buffers.size()));
  if (impl_->labels.size() >= kMaxDispatches) internal_error("gpu: too many dispatches in one sequence");
  auto& C = ctx_.impl();
  auto& f = C.f;
  const VkCommandBuffer cmd = impl_->cmd;
  if (!impl_->labels.empty()) {
    // The previous dispatch's writes are visible to this one's reads and writes.
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    f.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1,
                           &mb, 0, nullptr, 0, nullptr);
  }
  VkDescriptorSet set;
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = impl_->descriptors;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &k.impl().set_layout;
  vk::check(f.vkAllocateDescriptorSets(C.device, &ai, &set), "allocating a descriptor set");
  std::vector<VkDescriptorBufferInfo> infos;
  std::vector<VkWriteDescriptorSet> writes;
  infos.reserve(buffers.size());
  uint32_t i = 0;
  for (Buffer* b : buffers) {
    infos.push_back({b->impl().buffer, 0, VK_WHOLE_SIZE});
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = i++;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w.pBufferInfo = &infos.back();
    writes.push_back(w);
  }
  f.vkUpdateDescriptorSets(C.device, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
  f.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.impl().pipeline);
  f.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k.impl().layout, 0, 1, &set, 0, nullptr);
  if (k.push_bytes()) f.vkCmdPushConstants(cmd, k.impl().layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, k.push_bytes(), params);
  f.vkCmdDispatch(cmd, gx, gy, gz);
  impl_->labels.push_back(label.empty() ? k.name() : label);
  if (impl_->queries)
    f.vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, impl_->queries,
                          static_cast<uint32_t>(impl_->labels.size()));
}

void Sequence::submit_and_wait() {
  if (!impl_->recording) return;
  auto& C = ctx_.impl();
  auto& f = C.f;
  // The shaders' writes become visible to the host's reads of the mapped buffers.
  VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  f.vkCmdPipelineBarrier(impl_->cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb,
                         0, nullptr, 0, nullptr);
  vk::check(f.vkEndCommandBuffer(impl_->cmd), "ending a command buffer");
  impl_->recording = false;
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &impl_->cmd;
  vk::check(f.vkResetFences(C.device, 1, &impl_->fence), "resetting a fence");
  {
    std::lock_guard<std::mutex> q(C.queue_mutex);
    vk::check(f.vkQueueSubmit(C.queue, 1, &si, impl_->fence), "submitting work");
  }
  vk::check(f.vkWaitForFences(C.device, 1, &impl_->fence, VK_TRUE, UINT64_MAX), "waiting for the device");
  if (impl_->queries && !impl_->labels.empty()) {
    const uint32_t n = static_cast<uint32_t>(impl_->labels.size()) + 1;
    std::vector<uint64_t> t(n);
    vk::check(f.vkGetQueryPoolResults(C.device, impl_->queries, 0, n, n * sizeof(uint64_t), t.data(),
                                      sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
              "reading timestamps");
    const double period = ctx_.device().timestamp_period_ns;
    for (uint32_t i = 1; i < n; ++i) impl_->ms.push_back(static_cast<double>(t[i] - t[i - 1]) * period * 1e-6);
  }
}

double Sequence::device_ms() const {
  if (impl_->ms.empty()) return -1;
  double sum = 0;
  for (double ms : impl_->ms) sum += ms;
  return sum;
}

std::vector<Sequence::StageTime> Sequence::stage_times() const {
  std::vector<StageTime> out;
  for (size_t i = 0; i < impl_->ms.size(); ++i) out.push_back({impl_->labels[i], impl_->ms[i]});
  return out;
}

}  // namespace photosite::gpu
