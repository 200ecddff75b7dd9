// The driver registry: drivers compiled into this build, looked up by name.
#include "drivers/camera_driver.h"

namespace mocap {

DriverRegistry& DriverRegistry::instance() {
  static DriverRegistry registry;
  return registry;
}

void DriverRegistry::add(const std::string& name, Factory factory) {
  for (auto& [existing, f] : factories_) {
    if (existing == name) {
      f = std::move(factory);
      return;
    }
  }
  factories_.emplace_back(name, std::move(factory));
}

std::vector<std::string> DriverRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& entry : factories_) out.push_back(entry.first);
  return out;
}

std::unique_ptr<Driver> DriverRegistry::create(const std::string& name) const {
  for (const auto& [existing, factory] : factories_) {
    if (existing == name) return factory();
  }
  return nullptr;
}

}  // namespace mocap
