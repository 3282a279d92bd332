#include "server/served_methods.h"

namespace glint {

const google::protobuf::MethodDescriptor *FindServedMethod(const std::string &path) {
  if (path.size() < 4 || path[0] != '/') return nullptr;
  const size_t slash = path.rfind('/');
  if (slash == 0 || slash + 1 >= path.size()) return nullptr;
  const google::protobuf::ServiceDescriptor *service =
      google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
          path.substr(1, slash - 1));
  return service ? service->FindMethodByName(path.substr(slash + 1)) : nullptr;
}

}  // namespace glint
