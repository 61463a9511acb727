#include "api/byte_range.h"

#include <gtest/gtest.h>

namespace dfsm::api {
namespace {

TEST(ByteRangeTest, OneRangeOfBytesIsParsed) {
  auto range = ParseSingleByteRange("bytes=0-99");
  ASSERT_TRUE(range);
  EXPECT_EQ(FormatRangeSpec(*range), "0-99");
  EXPECT_EQ(FormatRangeSpec(*ParseSingleByteRange(" Bytes = 100- ")), "100-");
  EXPECT_EQ(FormatRangeSpec(*ParseSingleByteRange("bytes=-500")), "-500");
}

TEST(ByteRangeTest, AnythingButOneRangeOfBytesIsIgnored) {
  for (const char* value :
       {"bytes=0-,0-", "bytes=0-1,2-3", "items=0-5", "bytes=", "bytes=-", "bytes=abc-", "bytes=5-3",
        "bytes=0x10-", "bytes=1234567890123456789-", "bytes 0-5", "bytes=+1-2", "bytes=1 - 2"}) {
    EXPECT_FALSE(ParseSingleByteRange(value)) << value;
  }
}

TEST(ByteRangeTest, ARangeSelectsTheBytesOfTheRepresentation) {
  const auto slice = [](const char* value, uint64_t size) {
    return ResolveRange(*ParseSingleByteRange(value), size);
  };
  EXPECT_EQ(slice("bytes=100-199", 1000)->offset, 100u);
  EXPECT_EQ(slice("bytes=100-199", 1000)->length, 100u);
  EXPECT_EQ(slice("bytes=900-5000", 1000)->length, 100u);  // clipped to the end
  EXPECT_EQ(slice("bytes=900-", 1000)->length, 100u);
  EXPECT_EQ(slice("bytes=-10", 1000)->offset, 990u);
  EXPECT_EQ(slice("bytes=-5000", 1000)->offset, 0u);  // a suffix longer than the whole
  EXPECT_EQ(slice("bytes=-5000", 1000)->length, 1000u);
  EXPECT_FALSE(slice("bytes=1000-", 1000));  // 416
  EXPECT_FALSE(slice("bytes=-0", 1000));
  EXPECT_FALSE(slice("bytes=0-", 0));
}

}  // namespace
}  // namespace dfsm::api
