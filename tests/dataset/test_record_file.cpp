// The recording container (protocol/SPEC.md section 7): round trip, a file
// cut at every byte, corruption, versions, a write that fails for lack of
// space, and a writer killed with SIGKILL.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "dataset/record_file.h"
#include "protocol/crc32c.h"

namespace holofuse::dataset {
namespace {

namespace fs = std::filesystem;
using protocol::Bytes;
using protocol::crc32c;

class RecordFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("holofuse_record_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  static Bytes payloadFor(int i) {
    Bytes b(static_cast<size_t>(7 + 13 * i));
    for (size_t k = 0; k < b.size(); ++k)
      b[k] = static_cast<uint8_t>(k * 31 + static_cast<size_t>(i));
    return b;
  }

  // Writes count records (kinds cycling) and closes the file.
  void writeRecords(const std::string& file, int count) {
    auto writer = RecordWriter::create(file, 1234);
    ASSERT_TRUE(writer.isOk()) << writer.status().toString();
    for (int i = 0; i < count; ++i) {
      const auto kind = i == 0 ? RecordKind::kCalibration : RecordKind::kPodFrame;
      ASSERT_TRUE(writer
                      ->append(kind, static_cast<uint32_t>(i % 3), 100 + static_cast<uint64_t>(i),
                               1000 * static_cast<uint64_t>(i), payloadFor(i))
                      .isOk());
    }
    ASSERT_TRUE(writer->close().isOk());
  }

  static Bytes readFile(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), {});
  }
  static void writeFile(const std::string& file, const Bytes& bytes) {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
  }

  fs::path dir_;
};

TEST_F(RecordFileTest, RoundTripThroughTheIndex) {
  const std::string file = path("a.hfr");
  writeRecords(file, 6);
  auto reader = RecordReader::open(file);
  ASSERT_TRUE(reader.isOk()) << reader.status().toString();
  EXPECT_TRUE(reader->scan().index_found) << reader->scan().index_note;
  EXPECT_FALSE(reader->scan().tail_problem.has_value());
  EXPECT_EQ(reader->scan().created_unix_ns, 1234u);
  ASSERT_EQ(reader->records().size(), 6u);
  for (int i = 0; i < 6; ++i) {
    const RecordInfo& r = reader->records()[static_cast<size_t>(i)];
    EXPECT_EQ(r.kind,
              static_cast<uint16_t>(i == 0 ? RecordKind::kCalibration : RecordKind::kPodFrame));
    EXPECT_EQ(r.stream, static_cast<uint32_t>(i % 3));
    EXPECT_EQ(r.frame_id, 100u + static_cast<uint64_t>(i));
    EXPECT_EQ(r.time_ns, 1000u * static_cast<uint64_t>(i));
    auto payload = reader->read(r);
    ASSERT_TRUE(payload.isOk()) << payload.status().toString();
    EXPECT_EQ(*payload, payloadFor(i));
  }
  EXPECT_TRUE(reader->verifyAll().isOk());
}

TEST_F(RecordFileTest, ExistingFilesAreNeverOverwritten) {
  const std::string file = path("a.hfr");
  writeRecords(file, 1);
  auto again = RecordWriter::create(file, 0);
  ASSERT_FALSE(again.isOk());
  EXPECT_NE(again.status().message().find("never overwritten"), std::string::npos)
      << again.status().message();
}

// A recorder killed at any moment leaves a prefix of the closed file. For
// every prefix length, every record that lies wholly inside it reads back
// and the reader names exactly the bytes after the last whole record.
TEST_F(RecordFileTest, EveryCutKeepsEveryWholeRecordAndNamesTheRest) {
  const std::string file = path("full.hfr");
  writeRecords(file, 5);
  const Bytes full = readFile(file);
  auto complete = RecordReader::open(file);
  ASSERT_TRUE(complete.isOk());
  const auto all = complete->records();
  const uint64_t index_offset = all.back().end();
  for (size_t cut = kRecordFileHeaderSize; cut < full.size(); ++cut) {
    const std::string part = path("cut.hfr");
    writeFile(part, Bytes(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut)));
    auto reader = RecordReader::open(part);
    ASSERT_TRUE(reader.isOk()) << "cut at " << cut << ": " << reader.status().toString();
    EXPECT_FALSE(reader->scan().index_found) << "cut at " << cut;
    size_t whole = 0;
    while (whole < all.size() && all[whole].end() <= cut) ++whole;
    ASSERT_EQ(reader->records().size(), whole) << "cut at " << cut;
    EXPECT_TRUE(reader->verifyAll().isOk()) << "cut at " << cut;
    const uint64_t good_end = whole == 0 ? kRecordFileHeaderSize : all[whole - 1].end();
    EXPECT_EQ(reader->scan().good_end, good_end) << "cut at " << cut;
    if (cut == good_end && cut <= index_offset) {
      EXPECT_FALSE(reader->scan().tail_problem.has_value())
          << "cut at " << cut << ": " << *reader->scan().tail_problem;
    } else {
      ASSERT_TRUE(reader->scan().tail_problem.has_value()) << "cut at " << cut;
      EXPECT_TRUE(reader->scan().tail_incomplete) << *reader->scan().tail_problem;
      const std::string expected = "bytes " + std::to_string(good_end) + ".." + std::to_string(cut);
      EXPECT_EQ(reader->scan().tail_problem->rfind(expected, 0), 0u)
          << *reader->scan().tail_problem;
    }
  }
}

TEST_F(RecordFileTest, ACorruptPayloadIsFoundWithOrWithoutTheIndex) {
  const std::string file = path("a.hfr");
  writeRecords(file, 4);
  Bytes bytes = readFile(file);
  auto reader = RecordReader::open(file);
  ASSERT_TRUE(reader.isOk());
  const RecordInfo victim = reader->records()[2];
  bytes[victim.offset + kRecordHeaderSize + 3] ^= 0x40;
  writeFile(file, bytes);

  auto indexed = RecordReader::open(file);
  ASSERT_TRUE(indexed.isOk());
  EXPECT_TRUE(indexed->scan().index_found);
  const Status verified = indexed->verifyAll();
  ASSERT_FALSE(verified.isOk());
  EXPECT_EQ(verified.code(), StatusCode::kBadChecksum);
  EXPECT_NE(verified.message().find("at byte " + std::to_string(victim.offset)), std::string::npos)
      << verified.message();

  // Without the tail, the scan keeps the records before the damage.
  bytes.resize(bytes.size() - 1);
  writeFile(file, bytes);
  auto scanned = RecordReader::open(file);
  ASSERT_TRUE(scanned.isOk());
  EXPECT_EQ(scanned->records().size(), 2u);
  ASSERT_TRUE(scanned->scan().tail_problem.has_value());
  EXPECT_FALSE(scanned->scan().tail_incomplete);
  EXPECT_NE(scanned->scan().tail_problem->find("CRC32C mismatch"), std::string::npos)
      << *scanned->scan().tail_problem;
}

// Untrusted files: thousands of random corruptions (flipped bytes, a run
// of garbage, a lying length) never crash the reader, and every record it
// hands out either reads back or fails with a status.
TEST_F(RecordFileTest, RandomCorruptionIsAlwaysAStatusNeverACrash) {
  const std::string file = path("a.hfr");
  writeRecords(file, 6);
  const Bytes good = readFile(file);
  std::mt19937 random(11);
  size_t opened = 0, refused = 0;
  for (int round = 0; round < 3000; ++round) {
    Bytes bytes = good;
    const int flips = 1 + static_cast<int>(random() % 4);
    for (int k = 0; k < flips; ++k) {
      const size_t at = random() % bytes.size();
      switch (random() % 3) {
        case 0:
          bytes[at] ^= static_cast<uint8_t>(1u << (random() % 8));
          break;
        case 1:
          bytes[at] = static_cast<uint8_t>(random());
          break;
        default:
          bytes.resize(at);
          break;
      }
      if (bytes.size() < 2) break;
    }
    const std::string damaged = path("damaged.hfr");
    writeFile(damaged, bytes);
    auto reader = RecordReader::open(damaged);
    if (!reader.isOk()) {
      ++refused;
      EXPECT_FALSE(reader.status().message().empty());
      continue;
    }
    ++opened;
    for (const auto& r : reader->records()) {
      EXPECT_LE(r.end(), bytes.size());
      auto payload = reader->read(r);
      if (payload.isOk()) {
        EXPECT_EQ(payload->size(), r.payload_length);
      }
    }
  }
  EXPECT_GT(opened, 0u);
  EXPECT_GT(refused, 0u);
}

// A header whose CRC checks but whose length is huge (a hostile file):
// nothing is allocated for it, the scan stops there and names it.
TEST_F(RecordFileTest, ALyingLengthIsRefusedBeforeAllocating) {
  const std::string file = path("a.hfr");
  writeRecords(file, 4);
  Bytes bytes = readFile(file);
  auto reader = RecordReader::open(file);
  ASSERT_TRUE(reader.isOk());
  const RecordInfo victim = reader->records()[1];
  const uint32_t huge = kMaxRecordPayload;  // 1 GiB: allowed by the cap, far beyond the file
  const size_t h = victim.offset;
  for (int i = 0; i < 4; ++i)
    bytes[h + 12 + static_cast<size_t>(i)] = static_cast<uint8_t>(huge >> (8 * i));
  const uint32_t crc = crc32c(0, bytes.data() + h, kRecordHeaderSize - 4);
  for (int i = 0; i < 4; ++i)
    bytes[h + 36 + static_cast<size_t>(i)] = static_cast<uint8_t>(crc >> (8 * i));
  writeFile(file, bytes);
  // With the index: the record no longer matches its entry.
  auto indexed = RecordReader::open(file);
  ASSERT_TRUE(indexed.isOk());
  auto payload = indexed->read(indexed->records()[1]);
  ASSERT_FALSE(payload.isOk());
  EXPECT_NE(payload.status().message().find("differs from its index entry"), std::string::npos);
  // A caller's own record description that believes the header.
  RecordInfo believed = victim;
  believed.payload_length = huge;
  payload = indexed->read(believed);
  ASSERT_FALSE(payload.isOk());
  EXPECT_EQ(payload.status().code(), StatusCode::kTruncated);
  EXPECT_NE(payload.status().message().find("runs past the end of the file"), std::string::npos);
  // Without the tail the scan stops at the liar.
  bytes.resize(bytes.size() - 1);
  writeFile(file, bytes);
  auto scanned = RecordReader::open(file);
  ASSERT_TRUE(scanned.isOk());
  EXPECT_EQ(scanned->records().size(), 1u);
  ASSERT_TRUE(scanned->scan().tail_problem.has_value());
  EXPECT_NE(scanned->scan().tail_problem->find("of its 1073741824 payload bytes are present"),
            std::string::npos)
      << *scanned->scan().tail_problem;
}

TEST_F(RecordFileTest, ANewerFormatIsRefusedByName) {
  const std::string file = path("a.hfr");
  writeRecords(file, 1);
  Bytes bytes = readFile(file);
  bytes[8] = 2;   // format major 2
  bytes[10] = 3;  // minor 3
  const uint32_t crc = crc32c(0, bytes.data(), kRecordFileHeaderSize - 4);
  for (int i = 0; i < 4; ++i)
    bytes[kRecordFileHeaderSize - 4 + static_cast<size_t>(i)] =
        static_cast<uint8_t>(crc >> (8 * i));
  writeFile(file, bytes);
  auto reader = RecordReader::open(file);
  ASSERT_FALSE(reader.isOk());
  EXPECT_EQ(reader.status().code(), StatusCode::kUnsupportedVersion);
  EXPECT_NE(reader.status().message().find("format 2.3 is newer"), std::string::npos)
      << reader.status().message();
}

TEST_F(RecordFileTest, NotARecordingSaysSo) {
  const std::string file = path("a.hfr");
  writeFile(file, Bytes(64, 'x'));
  auto reader = RecordReader::open(file);
  ASSERT_FALSE(reader.isOk());
  EXPECT_EQ(reader.status().code(), StatusCode::kBadMagic);
  writeFile(file, Bytes(5, 'x'));
  EXPECT_EQ(RecordReader::open(file).status().code(), StatusCode::kTruncated);
}

// Out of space: the write fails, the failure says what and where, the file
// is cut back to whole records, and nothing more is written. The file size
// limit (RLIMIT_FSIZE) fails writes the way a full disk does, in a child
// process so the limit does not outlive the test.
TEST_F(RecordFileTest, AFullDiskIsReportedAndTheFileKeepsWholeRecords) {
  const std::string file = path("a.hfr");
  const std::string message_file = path("message.txt");
  const pid_t child = fork();
  if (child == 0) {
    signal(SIGXFSZ, SIG_IGN);
    rlimit limit{4000, 4000};
    setrlimit(RLIMIT_FSIZE, &limit);
    auto writer = RecordWriter::create(file, 0);
    if (!writer.isOk()) _exit(3);
    Bytes payload(300, 7);
    int appended = 0;
    Status s = Status::ok();
    while (
        (s = writer->append(RecordKind::kPodFrame, 0, static_cast<uint64_t>(appended), 0, payload))
            .isOk()) {
      ++appended;
    }
    const bool refuses_more = !writer->append(RecordKind::kPodFrame, 0, 0, 0, payload).isOk();
    std::ofstream(message_file) << appended << "\n" << refuses_more << "\n" << s.message() << "\n";
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  std::ifstream in(message_file);
  int appended = 0, refuses_more = 0;
  std::string message;
  in >> appended >> refuses_more;
  in.ignore();
  std::getline(in, message);
  EXPECT_EQ(appended, static_cast<int>((4000 - kRecordFileHeaderSize) / (kRecordHeaderSize + 300)));
  EXPECT_TRUE(refuses_more);
  EXPECT_NE(message.find("file size limit"), std::string::npos) << message;
  EXPECT_NE(message.find(std::to_string(appended) + " records"), std::string::npos) << message;
  auto reader = RecordReader::open(file);
  ASSERT_TRUE(reader.isOk());
  EXPECT_EQ(reader->records().size(), static_cast<size_t>(appended));
  EXPECT_FALSE(reader->scan().tail_problem.has_value()) << *reader->scan().tail_problem;
  EXPECT_TRUE(reader->verifyAll().isOk());
}

// A writer process killed with SIGKILL at a random moment: every record it
// finished is readable and checks.
TEST_F(RecordFileTest, AWriterKilledMidStreamLosesOnlyItsLastRecord) {
  std::mt19937 random(7);
  for (int round = 0; round < 4; ++round) {
    const std::string file = path("killed" + std::to_string(round) + ".hfr");
    const pid_t child = fork();
    if (child == 0) {
      auto writer = RecordWriter::create(file, 0);
      if (!writer.isOk()) _exit(3);
      Bytes payload(200000, 0);
      for (uint64_t i = 0;; ++i) {
        std::fill(payload.begin(), payload.end(), static_cast<uint8_t>(i));
        if (!writer->append(RecordKind::kPodFrame, 0, i, i, payload).isOk()) _exit(4);
      }
    }
    // Killed once the file has grown past a random point: after one to
    // four whole records and some way into the next, however fast the
    // machine writes.
    const uint64_t record = kRecordHeaderSize + 200000;
    const uint64_t kill_at =
        kRecordFileHeaderSize + record * (1 + random() % 4) + random() % record;
    int status = 0;
    bool exited = false;
    while (!exited && (!fs::exists(file) || fs::file_size(file) < kill_at)) {
      exited = waitpid(child, &status, WNOHANG) == child;
      usleep(1000);
    }
    ASSERT_FALSE(exited) << "the writer stopped by itself, status " << status;
    kill(child, SIGKILL);
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    auto reader = RecordReader::open(file);
    ASSERT_TRUE(reader.isOk()) << reader.status().toString();
    ASSERT_GT(reader->records().size(), 0u);
    EXPECT_TRUE(reader->verifyAll().isOk());
    for (size_t i = 0; i < reader->records().size(); ++i) {
      EXPECT_EQ(reader->records()[i].frame_id, i);
      auto payload = reader->read(reader->records()[i]);
      ASSERT_TRUE(payload.isOk());
      EXPECT_EQ((*payload)[payload->size() / 2], static_cast<uint8_t>(i));
    }
    const uint64_t size = fs::file_size(file);
    if (reader->scan().good_end < size) {
      ASSERT_TRUE(reader->scan().tail_problem.has_value());
      EXPECT_TRUE(reader->scan().tail_incomplete) << *reader->scan().tail_problem;
    } else {
      EXPECT_FALSE(reader->scan().tail_problem.has_value());
    }
  }
}

}  // namespace
}  // namespace holofuse::dataset
