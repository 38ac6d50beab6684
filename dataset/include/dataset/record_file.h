// The recording container of protocol/SPEC.md section 7: append-only typed
// records, each with a length and CRC32C, an index at a clean close, and a
// scanner that rebuilds the index and names the bytes a crash left behind.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/status.h"
#include "protocol/bytes.h"

namespace holofuse::protocol {
class OutgoingFrame;
}  // namespace holofuse::protocol

namespace holofuse::dataset {

constexpr uint16_t kRecordFormatMajor = 1;
constexpr uint16_t kRecordFormatMinor = 1;
constexpr size_t kRecordFileHeaderSize = 32;
constexpr size_t kRecordHeaderSize = 40;
constexpr size_t kRecordTailSize = 16;
constexpr uint32_t kMaxRecordPayload = 1u << 30;
constexpr uint32_t kServerStream = 0xFFFFFFFFu;

enum class RecordKind : uint16_t {
  kCalibration = 1,
  kPodFrame = 2,
  kMeshFrame = 3,
  kTextureBundle = 4,
  kStats = 5,
  kDatasetInfo = 6,  // JSON: dataset/metadata.h
  kIndex = 15,
};
const char* recordKindName(uint16_t kind);

struct RecordInfo {
  uint64_t offset = 0;  // of the record header in the file
  uint16_t kind = 0;
  uint32_t stream = 0;
  uint64_t frame_id = 0;
  uint64_t time_ns = 0;
  uint32_t payload_length = 0;
  uint64_t end() const { return offset + kRecordHeaderSize + payload_length; }
};

// Appends records to a new file. Not thread-safe. Every append is one
// writev of header and payload: a process killed mid-append leaves an
// incomplete last record that readers report and skip, never a record that
// reads back wrong. A failed write (full disk, file size limit) is
// reported with what was lost; the file is cut back to its last whole
// record and the writer refuses further appends.
class RecordWriter {
 public:
  RecordWriter() = default;
  ~RecordWriter();
  RecordWriter(RecordWriter&& other) noexcept;
  RecordWriter& operator=(RecordWriter&& other) noexcept;
  RecordWriter(const RecordWriter&) = delete;
  RecordWriter& operator=(const RecordWriter&) = delete;

  // Creates path (an existing file is an error: recordings are never
  // overwritten). created_unix_ns goes into the file header.
  static StatusOr<RecordWriter> create(const std::string& path, uint64_t created_unix_ns);

  Status append(RecordKind kind, uint32_t stream, uint64_t frame_id, uint64_t time_ns,
                std::span<const uint8_t> payload);
  // The same for a frame held as parts (no flattening copy).
  Status append(RecordKind kind, uint32_t stream, uint64_t frame_id, uint64_t time_ns,
                const protocol::OutgoingFrame& frame);
  // Writes the index and the tail and syncs the file to disk. Also done by
  // the destructor (errors then go to stderr).
  Status close();

  bool isOpen() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }
  uint64_t records() const { return index_.size(); }
  uint64_t bytes() const { return size_; }
  // The first failure, after which nothing more is written.
  const std::optional<Status>& failure() const { return failure_; }

 private:
  Status appendParts(RecordKind kind, uint32_t stream, uint64_t frame_id, uint64_t time_ns,
                     const std::vector<std::span<const uint8_t>>& payload, uint64_t payload_size);
  Status writeAll(std::span<const std::span<const uint8_t>> parts, uint64_t total,
                  const char* what);

  int fd_ = -1;
  std::string path_;
  uint64_t size_ = 0;
  std::vector<RecordInfo> index_;
  std::optional<Status> failure_;
};

// What a reader found in a file: where the index came from and what, if
// anything, is wrong with the bytes after the last good record.
struct RecordScan {
  uint16_t format_major = 0, format_minor = 0;
  uint64_t created_unix_ns = 0;
  uint64_t file_size = 0;
  bool index_found = false;  // the tail and index checked: no scan needed
  std::string index_note;    // why the index was rebuilt, if it was
  uint64_t good_end = 0;     // end of the last record that checks
  // Set when bytes good_end..file_size are not whole records: an incomplete
  // record (a crash mid-write) or corruption, said in words.
  std::optional<std::string> tail_problem;
  bool tail_incomplete = false;  // the problem is a record cut short by the end of the file
};

// Opens a recording, checks its header and version (a newer major is
// refused, named), and loads its index or rebuilds it by scanning.
class RecordReader {
 public:
  RecordReader() = default;
  ~RecordReader();
  RecordReader(RecordReader&& other) noexcept;
  RecordReader& operator=(RecordReader&& other) noexcept;
  RecordReader(const RecordReader&) = delete;
  RecordReader& operator=(const RecordReader&) = delete;

  static StatusOr<RecordReader> open(const std::string& path);

  const std::vector<RecordInfo>& records() const { return records_; }
  const RecordScan& scan() const { return scan_; }
  const std::string& path() const { return path_; }
  // Reads one record's payload and checks its CRCs.
  StatusOr<protocol::Bytes> read(const RecordInfo& record) const;
  // Reads every record and checks its CRCs (the index says where records
  // are, not that their bytes are intact); returns the first failure.
  Status verifyAll() const;

 private:
  Status loadIndex();
  void scanRecords();
  // Parses and checks one record header at offset (CRC of the header only).
  Status readHeader(uint64_t offset, RecordInfo& info, uint32_t& payload_crc) const;

  int fd_ = -1;
  std::string path_;
  RecordScan scan_;
  std::vector<RecordInfo> records_;
};

}  // namespace holofuse::dataset
