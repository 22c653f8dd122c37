// Admission of uploads, decided from the request header alone: an upload holds one slot from its
// header until its ingest has finished, and there are as many slots as the ingest pool has
// threads plus queue places. So an upload that would later find the ingest queue full is refused
// before a byte of its body is read or written to disk, rather than after it was staged.
// Optionally the bytes staged at once are capped too: each upload reserves its Content-Length (or
// the upload limit when it has none, as a chunked one) for as long as it holds its slot.
// Thread-safe: try_admit() and Slot release may run on any threads at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <mutex>

namespace zoomwarp::server {

class UploadAdmission {
 public:
  // `max_bytes` 0: no cap on bytes, only on slots.
  UploadAdmission(std::size_t slots, std::uint64_t max_bytes) : free_slots_(slots), max_bytes_(max_bytes) {}
  UploadAdmission(const UploadAdmission&) = delete;
  UploadAdmission& operator=(const UploadAdmission&) = delete;

  // A taken slot and its reserved bytes (or none); given back when the Slot is reset or destroyed.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& o) noexcept : owner_(o.owner_), bytes_(o.bytes_) { o.owner_ = nullptr; }
    Slot& operator=(Slot&& o) noexcept {
      if (this != &o) {
        reset();
        owner_ = o.owner_;
        bytes_ = o.bytes_;
        o.owner_ = nullptr;
      }
      return *this;
    }
    ~Slot() { reset(); }
    explicit operator bool() const { return owner_ != nullptr; }
    void reset() {
      if (owner_) owner_->give_back(bytes_);
      owner_ = nullptr;
    }

   private:
    friend class UploadAdmission;
    Slot(UploadAdmission* owner, std::uint64_t bytes) : owner_(owner), bytes_(bytes) {}
    UploadAdmission* owner_ = nullptr;
    std::uint64_t bytes_ = 0;
  };

  // A slot reserving `bytes`, or an empty Slot when all slots are taken or the bytes would go
  // over the cap.
  Slot try_admit(std::uint64_t bytes) {
    std::lock_guard lock(mu_);
    if (free_slots_ == 0) return Slot();
    if (max_bytes_ > 0 && (bytes > max_bytes_ || staged_bytes_ > max_bytes_ - bytes)) return Slot();
    --free_slots_;
    staged_bytes_ += bytes;
    return Slot(this, bytes);
  }

 private:
  void give_back(std::uint64_t bytes) {
    std::lock_guard lock(mu_);
    ++free_slots_;
    staged_bytes_ -= bytes;
  }

  std::mutex mu_;
  std::size_t free_slots_;
  const std::uint64_t max_bytes_;
  std::uint64_t staged_bytes_ = 0;
};

}  // namespace zoomwarp::server
