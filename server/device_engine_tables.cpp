// The device engine's per-request model tables (Model::request_table, e.g. an uploaded normal
// map): one read-only buffer per distinct table, shared by every queue and request that uses it.
// The buffer wraps the table's own memory (CL_MEM_USE_HOST_PTR: no copy on CPU devices, one
// upload on devices with their own memory); the engine holds only a weak reference, so the
// owner (the normal-map store) still decides when the memory goes, and an entry whose table
// has died is replaced, never used.
#include "server/device_engine.h"

namespace glint {

// *out is a reference of the caller's own (retained): a concurrent request may replace the
// cache entry while this one still runs.
Status DeviceEngine::RequestTableBufferFor(const EvalPlan &plan, ClBuffer *out) {
  std::lock_guard<std::mutex> lock(request_tables_mutex_);
  auto it = request_tables_.find(plan.request_table_key);
  if (it != request_tables_.end() && it->second.table.lock() == plan.request_table) {
    clRetainMemObject(it->second.buffer.get());
    out->reset(it->second.buffer.get());
    return Status::Ok();
  }
  // Forget buffers of tables nobody holds any more (evicted or deleted maps).
  for (auto e = request_tables_.begin(); e != request_tables_.end();)
    e = e->second.table.expired() ? request_tables_.erase(e) : std::next(e);
  cl_int err = CL_SUCCESS;
  RequestTableBuffer entry;
  entry.table = plan.request_table;
  entry.buffer.reset(clCreateBuffer(runtime_->context(), CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR,
                                    plan.request_table->size() * sizeof(float),
                                    const_cast<float *>(plan.request_table->data()), &err));
  if (err != CL_SUCCESS)
    return Status::Internal("clCreateBuffer (request table " + plan.request_table_key +
                            ") failed: " + ClErrorName(err));
  clRetainMemObject(entry.buffer.get());
  out->reset(entry.buffer.get());
  request_tables_[plan.request_table_key] = std::move(entry);
  return Status::Ok();
}

}  // namespace glint
