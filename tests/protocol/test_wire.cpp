// The one read cursor every binary format goes through: little-endian
// fields, LEB128 numbers, NUL-ended names and skipped arrays, each refused
// by field and offset when the bytes run out or lie.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "protocol/wire.h"

namespace holofuse::protocol {
namespace {

TEST(WireReader, FieldsAreLittleEndianWhateverTheHost) {
  const Bytes bytes = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x00, 0x00, 0x80, 0x3F};
  WireReader in(bytes);
  EXPECT_EQ(in.u16("a"), 0x0201);
  EXPECT_EQ(in.u32("b"), 0x06050403u);
  EXPECT_EQ(in.f32("c"), 1.0f);
  EXPECT_TRUE(in.ok());
  EXPECT_EQ(in.remaining(), 0u);
  Bytes written;
  WireWriter out(written);
  out.u16(0x0201);
  out.u32(0x06050403u);
  out.f32(1.0f);
  EXPECT_EQ(written, bytes) << "the writer lays fields out as the reader reads them";
}

TEST(WireReader, Leb128TakesUpTo32BitsAndRefusesMore) {
  // 300 = 0b1_0010_1100: 0xAC 0x02; 2^32 - 1 in five bytes.
  const Bytes bytes = {0xAC, 0x02, 0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0x80, 0x80, 0x80, 0x80, 0x10};
  WireReader in(bytes);
  EXPECT_EQ(in.varint32("small"), 300u);
  EXPECT_EQ(in.varint32("largest"), 0xFFFFFFFFu);
  EXPECT_EQ(in.varint32("too large"), 0u);
  ASSERT_FALSE(in.ok());
  EXPECT_EQ(in.failedField(), "too large");
  EXPECT_EQ(in.failedOffset(), 7u) << "the offset of the number, not of where reading stopped";
  EXPECT_NE(in.status().message().find("not a 32-bit LEB128"), std::string::npos);
  const Bytes short_bytes = {0x80, 0x80};
  WireReader unended(short_bytes);
  unended.varint32("unended");
  EXPECT_EQ(unended.status().code(), StatusCode::kTruncated) << unended.status().message();
}

TEST(WireReader, NamesEndAtTheirNulAndAnUnendedNameIsTruncated) {
  const Bytes bytes = {'a', 'b', 0, 'c', 'd'};
  WireReader in(bytes, 100);
  EXPECT_EQ(in.cstr("first"), "ab");
  EXPECT_EQ(in.offset(), 3u) << "past the NUL";
  EXPECT_EQ(in.cstr("second"), "");
  ASSERT_FALSE(in.ok());
  EXPECT_EQ(in.failedField(), "second");
  EXPECT_EQ(in.failedOffset(), 103u) << "base offset added";
}

TEST(WireReader, SkippingRefusesACountTheRestCannotHoldWithoutOverflow) {
  const Bytes bytes(48, 0);
  WireReader in(bytes);
  in.skip("two points", 2, 24);
  EXPECT_TRUE(in.ok());
  EXPECT_EQ(in.remaining(), 0u);
  WireReader hostile(bytes);
  // 2^61 x 8 wraps to 0 in 64 bits: a check of count * size would pass it.
  hostile.skip("points", uint64_t{1} << 61, 8);
  ASSERT_FALSE(hostile.ok());
  EXPECT_EQ(hostile.status().code(), StatusCode::kTruncated);
  EXPECT_EQ(hostile.failedField(), "points");
  EXPECT_EQ(hostile.u8("after"), 0) << "every read after the first failure fails";
  EXPECT_EQ(hostile.failedField(), "points") << "the first failure is kept";
}

// Arrays read at once are the same fields the one-at-a-time reads see, and
// an array longer than the rest is refused whole, leaving zeros.
TEST(WireReader, ArraysAreTheSameLittleEndianFieldsReadAtOnce) {
  const std::vector<uint32_t> indices = {1, 0x01020304u, 0xFFFFFFFFu};
  Bytes bytes;
  WireWriter out(bytes);
  out.array<uint32_t>(indices);
  ASSERT_EQ(bytes.size(), 12u);
  WireReader one_by_one(bytes);
  for (uint32_t index : indices) EXPECT_EQ(one_by_one.u32("an index"), index);
  std::vector<uint32_t> back(3);
  WireReader at_once(bytes);
  at_once.array<uint32_t>("the indices", back);
  EXPECT_EQ(back, indices);
  std::vector<uint32_t> too_many(4, 7);
  WireReader short_read(bytes);
  short_read.array<uint32_t>("the indices", too_many);
  ASSERT_FALSE(short_read.ok());
  EXPECT_EQ(short_read.failedField(), "the indices");
  EXPECT_EQ(too_many, std::vector<uint32_t>(4, 0));
}

}  // namespace
}  // namespace holofuse::protocol
