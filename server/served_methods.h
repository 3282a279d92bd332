// The gRPC methods glintd can serve, looked up by the path a client sends ("/pkg.Service/Method")
// in the protobuf descriptors compiled into the binary (glint.v1, the KServe v2 protocol,
// grpc.health.v1, reflection). A path that names none of them is a client's invention: the
// server answers it UNIMPLEMENTED, and nothing keyed by it (a metrics label, a message) may grow
// with the number of distinct paths clients send.
#pragma once

#include <google/protobuf/descriptor.h>

#include <string>

namespace glint {

// The method `path` names, or null when it is not "/<service full name>/<method>" of a service
// in the generated descriptor pool.
const google::protobuf::MethodDescriptor *FindServedMethod(const std::string &path);

}  // namespace glint
