#pragma once
// Frames of the launcher stream (launcher.h): a 4-byte little-endian length, then a
// MessagePack document. Used by both ends (launcher.cpp, serve_stream.cpp).
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

namespace stickslip::studies::stream {

/// Largest frame accepted [bytes]: a chunk of runs with traces stays far below it.
inline constexpr std::size_t kMaxFrame = std::size_t{1} << 30;

/// Writes all of data to fd (retrying short writes and EINTR); false on an error (EPIPE: the
/// reader is gone).
bool write_all(int fd, const std::uint8_t* data, std::size_t size);
/// The length prefix and doc's MessagePack bytes.
std::vector<std::uint8_t> frame_bytes(const nlohmann::json& doc);

/// Writes frames from several threads, one at a time; after a failed write it writes nothing
/// more and broken() is true.
class FrameWriter {
 public:
  explicit FrameWriter(int fd) : fd_(fd) {}
  bool write(const nlohmann::json& doc);
  bool broken() const;

 private:
  int fd_;
  mutable std::mutex mu_;
  bool broken_ = false;
};

/// Cuts a byte stream into frames. Throws wire::WireError for a frame above kMaxFrame or one
/// that is not MessagePack.
class FrameReader {
 public:
  void feed(const std::uint8_t* data, std::size_t size);
  std::optional<nlohmann::json> next();
  bool partial() const noexcept { return !buf_.empty(); }  ///< bytes of an unfinished frame

 private:
  std::vector<std::uint8_t> buf_;
  std::size_t pos_ = 0;
};

}  // namespace stickslip::studies::stream
