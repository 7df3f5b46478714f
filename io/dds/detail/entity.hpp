// Internal to io/dds: owns one Cyclone entity handle and deletes it (and its children) when
// destroyed. Creation checks the handle and throws; destruction never throws.
#pragma once

#include <dds/dds.h>

#include <cassert>
#include <stdexcept>
#include <string>
#include <utility>

namespace hvac_twin::dds::detail {

class Entity {
 public:
  Entity() = default;
  // Takes the result of a dds_create_* call. Throws std::runtime_error("cannot create <what>:
  // <Cyclone error>") if it is an error code.
  Entity(dds_entity_t handle, const std::string& what) : handle_(handle) {
    if (handle < 0) {
      handle_ = 0;
      throw std::runtime_error("cannot create DDS " + what + ": " + dds_strretcode(handle));
    }
  }
  ~Entity() { reset(); }
  Entity(Entity&& other) noexcept : handle_(std::exchange(other.handle_, 0)) {}
  Entity& operator=(Entity&& other) noexcept {
    if (this != &other) {
      reset();
      handle_ = std::exchange(other.handle_, 0);
    }
    return *this;
  }
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;

  dds_entity_t get() const noexcept { return handle_; }

  void reset() noexcept {
    if (handle_ > 0) {
      const dds_return_t rc = dds_delete(handle_);
      // ALREADY_DELETED: a parent (participant/domain) deleted it first, which is harmless.
      assert(rc == DDS_RETCODE_OK || rc == DDS_RETCODE_ALREADY_DELETED);
      (void)rc;
    }
    handle_ = 0;
  }

 private:
  dds_entity_t handle_ = 0;
};

}  // namespace hvac_twin::dds::detail
