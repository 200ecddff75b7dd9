// Ownership of the GLib objects and errors the Aravis API hands out, so every early return in the
// driver frees them. Internal to drivers/aravis/ (it pulls in <arv.h>).
#pragma once

#include <arv.h>

#include <memory>
#include <mutex>
#include <string>

namespace mocap::aravis {

struct GObjectUnref {
  void operator()(void* object) const { g_object_unref(object); }
};
template <typename T>
using GObjectPtr = std::unique_ptr<T, GObjectUnref>;

struct GFreeStrv {
  void operator()(const char** strings) const { g_free(strings); }
};
// Aravis' dup_*_as_strings return an array to g_free whose strings belong to the camera.
using BorrowedStrings = std::unique_ptr<const char*[], GFreeStrv>;

struct GFree {
  void operator()(void* memory) const { g_free(memory); }
};

// An out-parameter for Aravis calls: `call(..., error.out())`, then `if (error) ... error.message()`.
class GErrorHolder {
 public:
  GErrorHolder() = default;
  GErrorHolder(const GErrorHolder&) = delete;
  GErrorHolder& operator=(const GErrorHolder&) = delete;
  ~GErrorHolder() { clear(); }
  GError** out() {
    clear();
    return &error_;
  }
  explicit operator bool() const { return error_ != nullptr; }
  std::string message() const { return error_ ? error_->message : ""; }
  void clear() {
    if (error_) g_error_free(error_);
    error_ = nullptr;
  }

 private:
  GError* error_ = nullptr;
};

// Aravis' global device list and interface table are not thread-safe; every use goes through this.
std::mutex& systemMutex();

inline std::string orEmpty(const char* text) { return text ? text : ""; }

}  // namespace mocap::aravis
