// A ServerBuilder option that removes gRPC's reflection plugin.
//
// Linking grpc++_reflection registers the plugin from a static initialiser, so every
// ServerBuilder gets reflection whether or not InitProtoReflectionServerBuilderPlugin() is
// called; with --auth-tokens that exposed the service descriptions to callers without a token
// (found by an outside client). ServerBuilderOption::UpdatePlugins runs before the plugins add
// their services, so dropping the plugin there keeps the service off the server.
#pragma once

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/impl/server_builder_option.h>

#include <memory>
#include <vector>

namespace glint {

class WithoutReflection : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments *) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>> *plugins) override {
    std::erase_if(*plugins, [](const std::unique_ptr<grpc::ServerBuilderPlugin> &plugin) {
      return dynamic_cast<grpc::reflection::ProtoServerReflectionPlugin *>(plugin.get()) != nullptr;
    });
  }
};

}  // namespace glint
