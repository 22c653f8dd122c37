// Admission of uploads, decided from the request header alone: an upload holds one slot from its
// header until its ingest has finished, and there are as many slots as the ingest pool has
// threads plus queue places. So an upload that would later find the ingest queue full is refused
// before a byte of its body is read or written to disk, rather than after it was staged.
// Thread-safe: try_admit() and Slot release may run on any threads at once.
#pragma once

#include <atomic>
#include <cstddef>

namespace zoomwarp::server {

class UploadAdmission {
 public:
  explicit UploadAdmission(std::size_t slots) : free_(slots) {}
  UploadAdmission(const UploadAdmission&) = delete;
  UploadAdmission& operator=(const UploadAdmission&) = delete;

  // A taken slot (or none); the slot is given back when the Slot is reset or destroyed.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& o) noexcept : owner_(o.owner_) { o.owner_ = nullptr; }
    Slot& operator=(Slot&& o) noexcept {
      if (this != &o) {
        reset();
        owner_ = o.owner_;
        o.owner_ = nullptr;
      }
      return *this;
    }
    ~Slot() { reset(); }
    explicit operator bool() const { return owner_ != nullptr; }
    void reset() {
      if (owner_) owner_->free_.fetch_add(1);
      owner_ = nullptr;
    }

   private:
    friend class UploadAdmission;
    explicit Slot(UploadAdmission* owner) : owner_(owner) {}
    UploadAdmission* owner_ = nullptr;
  };

  // A slot, or an empty Slot when all are taken.
  Slot try_admit() {
    std::size_t free = free_.load();
    while (free > 0)
      if (free_.compare_exchange_weak(free, free - 1)) return Slot(this);
    return Slot();
  }

 private:
  std::atomic<std::size_t> free_;
};

}  // namespace zoomwarp::server
