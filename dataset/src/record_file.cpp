#include "dataset/record_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

#include "protocol/crc32c.h"
#include "protocol/frame.h"
#include "protocol/wire.h"

namespace holofuse::dataset {

using protocol::Bytes;
using protocol::crc32c;
using protocol::OutgoingFrame;
using protocol::WireReader;
using protocol::WireWriter;
namespace {

constexpr uint8_t kFileMagic[8] = {'H', 'F', 'R', 'E', 'C', '\r', '\n', 0x1A};
constexpr uint8_t kRecordMagic[4] = {'H', 'F', 'R', '1'};
constexpr uint8_t kTailMagic[8] = {'I', 'N', 'D', 'E', 'X', 'E', 'N', 'D'};
constexpr size_t kIndexEntrySize = 34;

std::string errnoText(int error) { return std::string(std::strerror(error)); }

Bytes encodeFileHeader(uint64_t created_unix_ns) {
  Bytes out;
  WireWriter w(out);
  w.raw(kFileMagic);
  w.u16(kRecordFormatMajor);
  w.u16(kRecordFormatMinor);
  w.u32(0);
  w.u64(created_unix_ns);
  w.u32(0);
  w.u32(crc32c(0, out.data(), out.size()));
  return out;
}

Bytes encodeRecordHeader(const RecordInfo& info, uint32_t payload_crc) {
  Bytes out;
  WireWriter w(out);
  w.raw(kRecordMagic);
  w.u16(info.kind);
  w.u16(0);
  w.u32(info.stream);
  w.u32(info.payload_length);
  w.u64(info.frame_id);
  w.u64(info.time_ns);
  w.u32(payload_crc);
  w.u32(crc32c(0, out.data(), out.size()));
  return out;
}

std::string at(uint64_t offset) { return " at byte " + std::to_string(offset); }

// pread until n bytes or the end of the file.
StatusOr<size_t> readAt(int fd, uint64_t offset, uint8_t* out, size_t n, const std::string& path) {
  size_t done = 0;
  while (done < n) {
    const ssize_t got = ::pread(fd, out + done, n - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0)
      return Status(StatusCode::kIoError,
                    path + ": read" + at(offset + done) + ": " + errnoText(errno));
    if (got == 0) break;
    done += static_cast<size_t>(got);
  }
  return done;
}

}  // namespace

const char* recordKindName(uint16_t kind) {
  switch (static_cast<RecordKind>(kind)) {
    case RecordKind::kCalibration:
      return "calibration";
    case RecordKind::kPodFrame:
      return "pod_frame";
    case RecordKind::kMeshFrame:
      return "mesh_frame";
    case RecordKind::kTextureBundle:
      return "texture_bundle";
    case RecordKind::kStats:
      return "stats";
    case RecordKind::kDatasetInfo:
      return "dataset_info";
    case RecordKind::kIndex:
      return "index";
  }
  return "unknown";
}

// ---------------------------------------------------------------- writer

RecordWriter::~RecordWriter() {
  if (fd_ < 0) return;
  const Status closed = close();
  if (!closed.isOk()) std::fprintf(stderr, "[record] %s\n", closed.toString().c_str());
}

RecordWriter::RecordWriter(RecordWriter&& other) noexcept { *this = std::move(other); }

RecordWriter& RecordWriter::operator=(RecordWriter&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) (void)close();
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
    size_ = other.size_;
    index_ = std::move(other.index_);
    failure_ = std::move(other.failure_);
  }
  return *this;
}

StatusOr<RecordWriter> RecordWriter::create(const std::string& path, uint64_t created_unix_ns) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) {
    return Status(StatusCode::kIoError,
                  path + ": cannot create (" + errnoText(errno) +
                      (errno == EEXIST ? "; recordings are never overwritten" : "") + ")");
  }
  RecordWriter writer;
  writer.fd_ = fd;
  writer.path_ = path;
  const Bytes header = encodeFileHeader(created_unix_ns);
  const std::span<const uint8_t> parts[] = {header};
  const Status written = writer.writeAll(parts, header.size(), "the file header");
  if (!written.isOk()) {
    // Nothing worth keeping: remove it so a retry is not refused.
    ::close(std::exchange(writer.fd_, -1));
    ::unlink(path.c_str());
    return written;
  }
  return writer;
}

Status RecordWriter::writeAll(std::span<const std::span<const uint8_t>> parts, uint64_t total,
                              const char* what) {
  if (failure_) return *failure_;
  if (fd_ < 0) return Status(StatusCode::kIoError, path_ + ": recording is closed");
  std::vector<iovec> iov;
  for (const auto& p : parts) {
    if (!p.empty()) iov.push_back({const_cast<uint8_t*>(p.data()), p.size()});
  }
  uint64_t written = 0;
  size_t first = 0;
  while (first < iov.size()) {
    const int count = static_cast<int>(std::min<size_t>(iov.size() - first, IOV_MAX));
    const ssize_t n = ::writev(fd_, iov.data() + first, count);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : EIO;
      // Cut the partial record off so the file ends on a whole record, and
      // say what was lost: nothing more is written to this file.
      const bool cut = ::ftruncate(fd_, static_cast<off_t>(size_)) == 0;
      std::string reason = errnoText(error);
      if (error == ENOSPC) reason = "disk full (" + reason + ")";
      if (error == EFBIG) reason = "file size limit reached (" + reason + ")";
      failure_ = Status(StatusCode::kIoError,
                        path_ + ": writing " + what + at(size_) + " failed after " +
                            std::to_string(written) + " of " + std::to_string(total) +
                            " bytes: " + reason + "; " + std::to_string(index_.size()) +
                            " records (" + std::to_string(size_) + " bytes) are kept" +
                            (cut ? "" : ", but the partial record could not be cut off") +
                            "; recording stopped");
      return *failure_;
    }
    written += static_cast<uint64_t>(n);
    size_t left = static_cast<size_t>(n);
    while (first < iov.size() && left >= iov[first].iov_len) left -= iov[first++].iov_len;
    if (left > 0) {
      iov[first].iov_base = static_cast<uint8_t*>(iov[first].iov_base) + left;
      iov[first].iov_len -= left;
    }
  }
  size_ += total;
  return Status::ok();
}

Status RecordWriter::append(RecordKind kind, uint32_t stream, uint64_t frame_id, uint64_t time_ns,
                            std::span<const uint8_t> payload) {
  return appendParts(kind, stream, frame_id, time_ns,
                     std::vector<std::span<const uint8_t>>{payload}, payload.size());
}

Status RecordWriter::append(RecordKind kind, uint32_t stream, uint64_t frame_id, uint64_t time_ns,
                            const OutgoingFrame& frame) {
  return appendParts(kind, stream, frame_id, time_ns, frame.parts(), frame.size());
}

Status RecordWriter::appendParts(RecordKind kind, uint32_t stream, uint64_t frame_id,
                                 uint64_t time_ns,
                                 const std::vector<std::span<const uint8_t>>& payload,
                                 uint64_t payload_size) {
  if (payload_size > kMaxRecordPayload) {
    return Status(StatusCode::kTooLarge,
                  path_ + ": a " + recordKindName(static_cast<uint16_t>(kind)) + " of " +
                      std::to_string(payload_size) + " bytes is above the record cap");
  }
  RecordInfo info;
  info.offset = size_;
  info.kind = static_cast<uint16_t>(kind);
  info.stream = stream;
  info.frame_id = frame_id;
  info.time_ns = time_ns;
  info.payload_length = static_cast<uint32_t>(payload_size);
  uint32_t crc = 0;
  for (const auto& part : payload) crc = crc32c(crc, part.data(), part.size());
  const Bytes header = encodeRecordHeader(info, crc);
  std::vector<std::span<const uint8_t>> parts;
  parts.push_back(header);
  parts.insert(parts.end(), payload.begin(), payload.end());
  HOLOFUSE_RETURN_IF_ERROR(
      writeAll(parts, header.size() + payload_size, recordKindName(info.kind)));
  index_.push_back(info);
  return Status::ok();
}

Status RecordWriter::close() {
  if (fd_ < 0) return Status::ok();
  Status result = Status::ok();  // a failure was reported when it happened
  if (!failure_) {
    Bytes index;
    WireWriter w(index);
    w.u64(index_.size());
    for (const auto& r : index_) {
      w.u64(r.offset);
      w.u16(r.kind);
      w.u32(r.stream);
      w.u64(r.frame_id);
      w.u64(r.time_ns);
      w.u32(r.payload_length);
    }
    RecordInfo info;
    info.offset = size_;
    info.kind = static_cast<uint16_t>(RecordKind::kIndex);
    info.stream = kServerStream;
    info.payload_length = static_cast<uint32_t>(index.size());
    const Bytes header = encodeRecordHeader(info, crc32c(0, index.data(), index.size()));
    Bytes tail;
    WireWriter t(tail);
    t.u64(info.offset);
    t.raw(kTailMagic);
    const std::span<const uint8_t> parts[] = {header, index, tail};
    result = writeAll(parts, header.size() + index.size() + tail.size(), "the index");
    if (result.isOk() && ::fdatasync(fd_) != 0) {
      result = Status(StatusCode::kIoError, path_ + ": fdatasync: " + errnoText(errno));
    }
  }
  ::close(fd_);
  fd_ = -1;
  return result;
}

// ---------------------------------------------------------------- reader

RecordReader::~RecordReader() {
  if (fd_ >= 0) ::close(fd_);
}

RecordReader::RecordReader(RecordReader&& other) noexcept { *this = std::move(other); }

RecordReader& RecordReader::operator=(RecordReader&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
    scan_ = std::move(other.scan_);
    records_ = std::move(other.records_);
  }
  return *this;
}

StatusOr<RecordReader> RecordReader::open(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    return Status(StatusCode::kIoError, path + ": cannot open (" + errnoText(errno) + ")");
  RecordReader reader;
  reader.fd_ = fd;
  reader.path_ = path;
  struct stat st {};
  if (::fstat(fd, &st) != 0)
    return Status(StatusCode::kIoError, path + ": stat: " + errnoText(errno));
  reader.scan_.file_size = static_cast<uint64_t>(st.st_size);
  uint8_t header[kRecordFileHeaderSize];
  auto got = readAt(fd, 0, header, sizeof(header), path);
  if (!got.isOk()) return got.status();
  if (*got < sizeof(header)) {
    return Status(StatusCode::kTruncated, path + ": " + std::to_string(*got) +
                                              " bytes, shorter than the 32-byte recording header");
  }
  if (std::memcmp(header, kFileMagic, sizeof(kFileMagic)) != 0) {
    return Status(StatusCode::kBadMagic,
                  path + ": not a holofuse recording (bad magic in the first 8 bytes)");
  }
  WireReader r(std::span<const uint8_t>(header + 8, sizeof(header) - 8));
  reader.scan_.format_major = r.u16("format major");
  reader.scan_.format_minor = r.u16("format minor");
  const uint32_t flags = r.u32("flags");
  reader.scan_.created_unix_ns = r.u64("created");
  const uint32_t reserved = r.u32("reserved");
  const uint32_t crc = r.u32("header crc");
  if (crc != crc32c(0, header, kRecordFileHeaderSize - 4)) {
    return Status(StatusCode::kBadChecksum,
                  path + ": the recording header's CRC32C does not match (bytes 0..31)");
  }
  if (reader.scan_.format_major > kRecordFormatMajor) {
    return Status(StatusCode::kUnsupportedVersion,
                  path + ": recording format " + std::to_string(reader.scan_.format_major) + "." +
                      std::to_string(reader.scan_.format_minor) +
                      " is newer than this holofuse reads (" + std::to_string(kRecordFormatMajor) +
                      ".x); use a newer holofuse");
  }
  if (flags != 0 || reserved != 0) {
    return Status(StatusCode::kReservedNonZero,
                  path + ": reserved header bits are set (flags " + std::to_string(flags) + ")");
  }
  const Status index = reader.loadIndex();
  if (!index.isOk()) {
    reader.scan_.index_note = index.message();
    reader.scanRecords();
  }
  return reader;
}

Status RecordReader::readHeader(uint64_t offset, RecordInfo& info, uint32_t& payload_crc) const {
  uint8_t header[kRecordHeaderSize];
  auto got = readAt(fd_, offset, header, sizeof(header), path_);
  if (!got.isOk()) return got.status();
  if (*got < sizeof(header)) {
    return Status(StatusCode::kTruncated, "a record header" + at(offset) +
                                              " is cut short: " + std::to_string(*got) + " of " +
                                              std::to_string(kRecordHeaderSize) + " bytes present");
  }
  if (std::memcmp(header, kRecordMagic, sizeof(kRecordMagic)) != 0) {
    return Status(StatusCode::kBadMagic, "no record magic" + at(offset));
  }
  WireReader r(std::span<const uint8_t>(header + 4, sizeof(header) - 4));
  info.offset = offset;
  info.kind = r.u16("kind");
  const uint16_t reserved = r.u16("reserved");
  info.stream = r.u32("stream");
  info.payload_length = r.u32("payload length");
  info.frame_id = r.u64("frame id");
  info.time_ns = r.u64("time");
  payload_crc = r.u32("payload crc");
  const uint32_t header_crc = r.u32("header crc");
  if (header_crc != crc32c(0, header, kRecordHeaderSize - 4)) {
    return Status(StatusCode::kBadChecksum, "record header" + at(offset) + ": CRC32C mismatch");
  }
  if (reserved != 0)
    return Status(StatusCode::kReservedNonZero,
                  "record header" + at(offset) + ": reserved bits set");
  if (info.payload_length > kMaxRecordPayload) {
    return Status(StatusCode::kTooLarge, "record" + at(offset) + ": payload length " +
                                             std::to_string(info.payload_length) +
                                             " above the 1 GiB cap");
  }
  return Status::ok();
}

Status RecordReader::loadIndex() {
  const uint64_t size = scan_.file_size;
  if (size < kRecordFileHeaderSize + kRecordHeaderSize + kRecordTailSize) {
    return Status(StatusCode::kTruncated, "no index (the file is too short to hold one)");
  }
  uint8_t tail[kRecordTailSize];
  auto got = readAt(fd_, size - kRecordTailSize, tail, sizeof(tail), path_);
  if (!got.isOk()) return got.status();
  if (*got < sizeof(tail) || std::memcmp(tail + 8, kTailMagic, sizeof(kTailMagic)) != 0) {
    return Status(StatusCode::kBadMagic,
                  "no index at the end (the recording was not closed cleanly)");
  }
  WireReader tr(std::span<const uint8_t>(tail, 8));
  const uint64_t index_offset = tr.u64("index offset");
  RecordInfo info;
  uint32_t payload_crc = 0;
  if (index_offset < kRecordFileHeaderSize ||
      index_offset > size - kRecordTailSize - kRecordHeaderSize) {
    return Status(StatusCode::kMalformed, "the tail points outside the file");
  }
  HOLOFUSE_RETURN_IF_ERROR(readHeader(index_offset, info, payload_crc));
  if (info.kind != static_cast<uint16_t>(RecordKind::kIndex) ||
      info.end() + kRecordTailSize != size) {
    return Status(StatusCode::kMalformed, "the tail does not point at an index record");
  }
  Bytes payload(info.payload_length);
  auto read = readAt(fd_, info.offset + kRecordHeaderSize, payload.data(), payload.size(), path_);
  if (!read.isOk()) return read.status();
  if (*read < payload.size() || crc32c(0, payload.data(), payload.size()) != payload_crc) {
    return Status(StatusCode::kBadChecksum, "the index record's CRC32C does not match");
  }
  WireReader r(payload);
  const uint64_t count = r.u64("index count");
  if (!r.status().isOk() || count > (payload.size() - 8) / kIndexEntrySize) {
    return Status(StatusCode::kMalformed, "the index's count does not fit its length");
  }
  std::vector<RecordInfo> records;
  uint64_t expected_offset = kRecordFileHeaderSize;
  for (uint64_t i = 0; i < count; ++i) {
    RecordInfo e;
    e.offset = r.u64("offset");
    e.kind = r.u16("kind");
    e.stream = r.u32("stream");
    e.frame_id = r.u64("frame id");
    e.time_ns = r.u64("time");
    e.payload_length = r.u32("payload length");
    // Records are back to back: an index that says otherwise is not trusted.
    if (e.offset != expected_offset || e.payload_length > kMaxRecordPayload ||
        e.end() > index_offset) {
      return Status(StatusCode::kMalformed,
                    "index entry " + std::to_string(i) + " does not match the file layout");
    }
    expected_offset = e.end();
    records.push_back(e);
  }
  if (!r.status().isOk() || expected_offset != index_offset) {
    return Status(StatusCode::kMalformed, "the index does not cover the file up to itself");
  }
  records_ = std::move(records);
  scan_.index_found = true;
  scan_.good_end = size;
  return Status::ok();
}

void RecordReader::scanRecords() {
  records_.clear();
  uint64_t offset = kRecordFileHeaderSize;
  const uint64_t size = scan_.file_size;
  Bytes payload;
  while (offset < size) {
    RecordInfo info;
    uint32_t payload_crc = 0;
    const Status header = readHeader(offset, info, payload_crc);
    if (!header.isOk()) {
      scan_.tail_incomplete = header.code() == StatusCode::kTruncated;
      scan_.tail_problem = header.message();
      break;
    }
    if (info.end() > size) {
      scan_.tail_incomplete = true;
      scan_.tail_problem =
          "the " + std::string(recordKindName(info.kind)) + " record" + at(offset) +
          " is incomplete: " + std::to_string(size - offset - kRecordHeaderSize) + " of its " +
          std::to_string(info.payload_length) + " payload bytes are present";
      break;
    }
    payload.resize(info.payload_length);
    auto read = readAt(fd_, offset + kRecordHeaderSize, payload.data(), payload.size(), path_);
    if (!read.isOk() || *read < payload.size() ||
        crc32c(0, payload.data(), payload.size()) != payload_crc) {
      scan_.tail_problem = "the " + std::string(recordKindName(info.kind)) + " record" +
                           at(offset) + ": payload CRC32C mismatch (corrupt bytes)";
      break;
    }
    if (info.kind == static_cast<uint16_t>(RecordKind::kIndex)) {
      // An index with no valid tail after it: the close was cut short.
      offset = info.end();
      if (size - offset < kRecordTailSize) {
        scan_.tail_incomplete = true;
        scan_.tail_problem =
            "the index" + at(info.offset) + " is whole but its 16-byte tail is cut short";
      } else if (size - offset > kRecordTailSize) {
        continue;  // records after an index: keep scanning
      }
      break;
    }
    records_.push_back(info);
    offset = info.end();
  }
  scan_.good_end = records_.empty() ? kRecordFileHeaderSize : records_.back().end();
  if (scan_.tail_problem) {
    scan_.tail_problem = "bytes " + std::to_string(scan_.good_end) + ".." + std::to_string(size) +
                         " (" + std::to_string(size - scan_.good_end) +
                         " bytes) after the last whole record: " + *scan_.tail_problem;
  }
}

StatusOr<Bytes> RecordReader::read(const RecordInfo& record) const {
  RecordInfo info;
  uint32_t payload_crc = 0;
  Status header = readHeader(record.offset, info, payload_crc);
  if (!header.isOk()) return Status(header.code(), path_ + ": " + header.message());
  if (info.kind != record.kind || info.payload_length != record.payload_length ||
      info.stream != record.stream || info.frame_id != record.frame_id) {
    return Status(StatusCode::kMalformed,
                  path_ + ": the record" + at(record.offset) + " differs from its index entry");
  }
  // Checked before allocating: a header may lie about its length.
  if (info.end() > scan_.file_size) {
    return Status(StatusCode::kTruncated,
                  path_ + ": the record" + at(record.offset) + " runs past the end of the file");
  }
  Bytes payload(info.payload_length);
  auto got = readAt(fd_, info.offset + kRecordHeaderSize, payload.data(), payload.size(), path_);
  if (!got.isOk()) return got.status();
  if (*got < payload.size()) {
    return Status(StatusCode::kTruncated,
                  path_ + ": the record" + at(record.offset) + " is cut short");
  }
  if (crc32c(0, payload.data(), payload.size()) != payload_crc) {
    return Status(StatusCode::kBadChecksum, path_ + ": the " +
                                                std::string(recordKindName(info.kind)) + " record" +
                                                at(record.offset) + ": payload CRC32C mismatch");
  }
  return payload;
}

Status RecordReader::verifyAll() const {
  for (const auto& record : records_) {
    auto payload = read(record);
    if (!payload.isOk()) return payload.status();
  }
  return Status::ok();
}

}  // namespace holofuse::dataset
