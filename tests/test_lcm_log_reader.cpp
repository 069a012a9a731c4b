// The bounded LCM log reader: every good event read, damage counted and skipped,
// never more memory than its buffer, same answers from a file and from memory.
#include <gtest/gtest.h>

#include <lcm/eventlog.h>

#include <cstdio>
#include <string>
#include <vector>

#include "hal/lcm/lcm_log_reader.hpp"

namespace zonemap::lcm_link {
namespace {

void put32(std::vector<std::uint8_t>* out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out->push_back(static_cast<std::uint8_t>(v >> shift));
}

void put64(std::vector<std::uint8_t>* out, std::uint64_t v) {
  put32(out, static_cast<std::uint32_t>(v >> 32));
  put32(out, static_cast<std::uint32_t>(v));
}

// One event as the LCM log format lays it out; lengths may lie.
void put_event(std::vector<std::uint8_t>* out, std::int64_t number, const std::string& channel,
               const std::vector<std::uint8_t>& data, std::int64_t claimed_data_length = -1) {
  put32(out, LcmLogReader::kSync);
  put64(out, static_cast<std::uint64_t>(number));
  put64(out, static_cast<std::uint64_t>(1'000'000 + number * 1000));
  put32(out, static_cast<std::uint32_t>(channel.size()));
  put32(out, static_cast<std::uint32_t>(claimed_data_length >= 0
                                            ? claimed_data_length
                                            : static_cast<std::int64_t>(data.size())));
  out->insert(out->end(), channel.begin(), channel.end());
  out->insert(out->end(), data.begin(), data.end());
}

std::vector<std::uint8_t> payload(std::int64_t number, std::size_t size = 40) {
  std::vector<std::uint8_t> data(size);
  for (std::size_t i = 0; i < size; ++i) data[i] = static_cast<std::uint8_t>(number * 7 + i);
  return data;
}

struct ReadBack {
  std::vector<std::int64_t> numbers;  // of the INS events read
  std::int64_t damaged = 0, oversized = 0;
  bool payloads_intact = true;
};

ReadBack read_all(LcmLogReader& reader) {
  ReadBack r;
  LcmLogEvent event;
  for (int guard = 0; guard < 1'000'000; ++guard) {
    const LcmLogRead read = reader.next(&event);
    if (read == LcmLogRead::kEnd) break;
    if (read != LcmLogRead::kEvent || event.channel != "INS") continue;
    r.numbers.push_back(event.event_number);
    const auto expected = payload(event.event_number);
    r.payloads_intact = r.payloads_intact && event.size == expected.size() &&
                        std::equal(expected.begin(), expected.end(), event.data) &&
                        event.timestamp_us == 1'000'000 + event.event_number * 1000;
  }
  r.damaged = reader.damaged();
  r.oversized = reader.oversized();
  return r;
}

// Read from memory and from a file: both must give the same.
ReadBack read_both_ways(const std::vector<std::uint8_t>& bytes, const char* name) {
  LcmLogReader memory;
  memory.open_memory(bytes.data(), bytes.size());
  const ReadBack from_memory = read_all(memory);
  const std::string path = ::testing::TempDir() + "/" + name + ".lcmlog";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  EXPECT_NE(f, nullptr);
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
  LcmLogReader file;
  std::string error;
  EXPECT_TRUE(file.open(path, &error)) << error;
  const ReadBack from_file = read_all(file);
  EXPECT_EQ(from_memory.numbers, from_file.numbers) << name;
  EXPECT_EQ(from_memory.damaged, from_file.damaged) << name;
  EXPECT_EQ(from_memory.oversized, from_file.oversized) << name;
  return from_file;
}

std::vector<std::int64_t> range(std::int64_t first, std::int64_t last) {
  std::vector<std::int64_t> v;
  for (std::int64_t i = first; i <= last; ++i) v.push_back(i);
  return v;
}

TEST(LcmLogReader, ReadsWhatLcmsOwnWriterWrote) {
  const std::string path = ::testing::TempDir() + "/lcm-writer.lcmlog";
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  for (std::int64_t i = 0; i < 3000; ++i) {  // ~200 KB: several buffer refills
    auto data = payload(i);
    lcm_eventlog_event_t e{};
    e.timestamp = 1'000'000 + i * 1000;
    e.channellen = 3;
    e.datalen = static_cast<std::int32_t>(data.size());
    e.channel = const_cast<char*>("INS");
    e.data = data.data();
    ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
  }
  lcm_eventlog_destroy(log);
  LcmLogReader reader;
  std::string error;
  ASSERT_TRUE(reader.open(path, &error)) << error;
  const ReadBack r = read_all(reader);
  EXPECT_EQ(r.numbers, range(0, 2999));
  EXPECT_TRUE(r.payloads_intact);
  EXPECT_EQ(r.damaged, 0);
}

TEST(LcmLogReader, AHugeClaimedLengthIsSkippedNotAllocated) {
  // liblcm 1.3.1 crashes on this event (datalen + 1 overflows, fread into NULL)
  // and stops reading there; the events after it must not be lost.
  std::vector<std::uint8_t> bytes;
  for (int i = 0; i < 10; ++i) put_event(&bytes, i, "INS", payload(i));
  put_event(&bytes, 99, "INS", payload(99), 0x7FFFFFFF);
  for (int i = 10; i < 20; ++i) put_event(&bytes, i, "INS", payload(i));
  const ReadBack r = read_both_ways(bytes, "huge-length");
  EXPECT_EQ(r.numbers, range(0, 19));
  EXPECT_TRUE(r.payloads_intact);
  EXPECT_EQ(r.damaged, 1);
}

TEST(LcmLogReader, GarbageAndBadLengthsAreCountedAndSkipped) {
  std::vector<std::uint8_t> bytes;
  for (int i = 0; i < 5; ++i) put_event(&bytes, i, "INS", payload(i));
  for (int i = 0; i < 333; ++i) bytes.push_back(static_cast<std::uint8_t>(i * 31));  // noise
  put_event(&bytes, 5, "INS", payload(5));
  put_event(&bytes, 98, "", payload(98));                     // empty channel: not a header
  put_event(&bytes, 97, std::string(300, 'c'), payload(97));  // channel too long
  put_event(&bytes, 6, "INS", payload(6));
  put_event(&bytes, 96, "INS", payload(96), 0xFFFFFFFB);  // data length -5
  put_event(&bytes, 7, "INS", payload(7));
  const ReadBack r = read_both_ways(bytes, "garbage");
  EXPECT_EQ(r.numbers, range(0, 7));
  EXPECT_TRUE(r.payloads_intact);
  EXPECT_EQ(r.damaged, 4);  // the noise, then each bad header
}

TEST(LcmLogReader, OversizedEventsOfOtherChannelsAreSkippedWithoutReadingThem) {
  std::vector<std::uint8_t> bytes;
  for (int i = 0; i < 5; ++i) {
    put_event(&bytes, i, "INS", payload(i));
    // A 300 KB image between poses: larger than the reader's whole buffer.
    put_event(&bytes, 1000 + i, "CAMERA", std::vector<std::uint8_t>(300'000, 0xAB));
  }
  const ReadBack r = read_both_ways(bytes, "oversized");
  EXPECT_EQ(r.numbers, range(0, 4));
  EXPECT_EQ(r.oversized, 5);
  EXPECT_EQ(r.damaged, 0);
}

TEST(LcmLogReader, ATornLastEventIsCountedAndEndsTheLog) {
  std::vector<std::uint8_t> bytes;
  for (int i = 0; i < 4; ++i) put_event(&bytes, i, "INS", payload(i));
  put_event(&bytes, 4, "INS", payload(4));
  bytes.erase(bytes.end() - 10, bytes.end());
  const ReadBack r = read_both_ways(bytes, "torn");
  EXPECT_EQ(r.numbers, range(0, 3));
  EXPECT_EQ(r.damaged, 1);
  bytes.erase(bytes.end() - 50, bytes.end());  // now inside the header
  EXPECT_EQ(read_both_ways(bytes, "torn-header").damaged, 1);
}

}  // namespace
}  // namespace zonemap::lcm_link
