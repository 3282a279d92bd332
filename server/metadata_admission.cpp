#include "server/metadata_admission.h"

#include <cstdlib>
#include <string>

#include "glint/v1/glint.pb.h"

namespace glint {

Status AdmitFromMetadata(const grpc::CallbackServerContext &ctx, const ValidationLimits &limits,
                         bool per_message) {
  const auto &md = ctx.client_metadata();
  if (auto it = md.find(kQueryCountMetadata); it != md.end()) {
    const std::string text(it->second.data(), it->second.size());
    char *end = nullptr;
    const unsigned long long count = std::strtoull(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || text[0] == '-')
      return Status::InvalidArgument(std::string("call metadata ") + kQueryCountMetadata + ": '" +
                                     text + "'; expected a decimal query count");
    if (per_message && count > limits.max_batch)
      return Status::InvalidArgument(
          "queries.count: " + std::to_string(count) + " (call metadata " + kQueryCountMetadata +
          ", refused before the body was parsed) exceeds the server's max_batch of " +
          std::to_string(limits.max_batch) + "; split the batch or use EvaluateStream");
  }
  if (auto it = md.find(kModelMetadata); it != md.end()) {
    const std::string name(it->second.data(), it->second.size());
    glint::v1::Model model;
    if (!glint::v1::Model_Parse(name, &model))
      return Status::InvalidArgument(std::string("call metadata ") + kModelMetadata + ": '" + name +
                                     "' is not a glint.v1.Model name");
  }
  return Status::Ok();
}

}  // namespace glint
