#include "firmware/lib/frame_source.h"

#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>

namespace mfns::fw {
namespace {

TEST(SourceStatus, EveryValueHasADistinctName) {
  std::set<std::string> names;
  const int last = static_cast<int>(SourceStatus::kStreamFailed);
  for (int i = 0; i <= last; ++i) {
    const char* name = ToString(static_cast<SourceStatus>(i));
    EXPECT_STRNE(name, "unknown") << i;
    names.insert(name);
  }
  EXPECT_EQ(names.size(), static_cast<std::size_t>(last + 1));
  EXPECT_STREQ(ToString(static_cast<SourceStatus>(last + 1)), "unknown");
}

TEST(SequenceTracker, CountsGapsAsDrops) {
  SourceCounters c;
  SequenceTracker t;
  for (std::uint32_t s : {10U, 11U, 12U, 15U, 16U, 20U}) t.Observe(s, &c);
  EXPECT_EQ(c.drops, 2U + 3U);  // 13, 14 and 17, 18, 19
  EXPECT_EQ(c.sequence_resets, 0U);
}

TEST(SequenceTracker, FirstFrameIsNeverADrop) {
  SourceCounters c;
  SequenceTracker t;
  t.Observe(1000, &c);
  EXPECT_EQ(c.drops, 0U);
}

TEST(SequenceTracker, WrapsAroundTwoToThe32) {
  SourceCounters c;
  SequenceTracker t;
  t.Observe(0xFFFFFFFEU, &c);
  t.Observe(0xFFFFFFFFU, &c);
  t.Observe(0U, &c);
  t.Observe(2U, &c);  // 1 lost
  EXPECT_EQ(c.drops, 1U);
  EXPECT_EQ(c.sequence_resets, 0U);
}

TEST(SequenceTracker, StepBackIsAResetNotFourBillionDrops) {
  SourceCounters c;
  SequenceTracker t;
  t.Observe(500, &c);
  t.Observe(3, &c);
  t.Observe(3, &c);  // repeated: also backwards
  t.Observe(4, &c);
  EXPECT_EQ(c.drops, 0U);
  EXPECT_EQ(c.sequence_resets, 2U);
}

TEST(SequenceTracker, ResetForgetsTheLastSequence) {
  SourceCounters c;
  SequenceTracker t;
  t.Observe(5, &c);
  t.Reset();
  t.Observe(100, &c);
  EXPECT_EQ(c.drops, 0U);
}

}  // namespace
}  // namespace mfns::fw
