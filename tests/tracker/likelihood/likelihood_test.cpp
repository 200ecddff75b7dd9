// The masked chain: a silhouette pixel explained by an earlier segment is never credited again.
#include "tracker/likelihood/likelihood.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include <opencv2/core.hpp>

#include <opencv2/imgproc.hpp>

namespace mocap {
namespace {

// A rectangle footprint [x0, x1) x [y0, y1) backed by `storage`.
Footprint rect(int x0, int x1, int y0, int y1, std::vector<RowSpan>& storage) {
  storage.assign(y1 - y0, RowSpan{static_cast<int16_t>(x0), static_cast<int16_t>(x1)});
  return Footprint{y0, y1, x0, x1, storage.data()};
}

TEST(Likelihood, CountsMatchedAndOutsidePixels) {
  cv::Mat image = cv::Mat::zeros(100, 100, CV_8UC1);
  image(cv::Rect(10, 10, 40, 40)) = 255;  // silhouette: x, y in [10, 50)
  const SilhouetteMask mask(image);
  std::vector<RowSpan> s;
  const Footprint f = rect(30, 80, 20, 30, s);  // 50 x 10, 20 x 10 of it on the silhouette
  const PixelCounts c = countFootprint(mask, f, nullptr, 0);
  EXPECT_EQ(c.area, 500);
  EXPECT_EQ(c.matched, 200);
  EXPECT_EQ(c.outside, 300);
  LikelihoodParams p;
  p.beta = 0.5;
  EXPECT_DOUBLE_EQ(logLikelihood(p, c), 0.5 * (200 - 300));
}

TEST(Likelihood, APixelExplainedOnceIsNotCountedTwice) {
  cv::Mat image = cv::Mat::zeros(100, 100, CV_8UC1);
  image(cv::Rect(0, 0, 100, 100)) = 255;
  const SilhouetteMask mask(image);
  std::vector<RowSpan> sa, sb, sc;
  const Footprint a = rect(10, 40, 10, 20, sa);  // 300 px
  const Footprint b = rect(30, 60, 15, 25, sb);  // 300 px, overlapping a by 10 x 5 = 50
  const Footprint c = rect(35, 50, 0, 100, sc);  // overlaps both
  EXPECT_EQ(countFootprint(mask, b, &a, 1).matched, 250);
  const Footprint explained[] = {a, b};
  // c covers 15 x 100 = 1500; a covers c in x[35,40) y[10,20) = 50, b in x[35,50) y[15,25) = 150,
  // their union inside c: 50 + 150 - 25 (the x[35,40) y[15,20) corner) = 175.
  const PixelCounts counts = countFootprint(mask, c, explained, 2);
  EXPECT_EQ(counts.area, 1500);
  EXPECT_EQ(counts.matched, 1500 - 175);
  EXPECT_EQ(counts.outside, 0);
}

TEST(Likelihood, ChainCreditsEachSilhouettePixelAtMostOnceOverRandomFootprints) {
  // Summing the matched counts along a chain equals the silhouette pixels covered by the union.
  std::mt19937 rng(5);
  cv::Mat image(120, 160, CV_8UC1);
  cv::randu(image, 0, 2);
  image *= 255;
  const SilhouetteMask mask(image);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<std::vector<RowSpan>> storage(6);
    std::vector<Footprint> chain;
    cv::Mat union_mask = cv::Mat::zeros(image.size(), CV_8UC1);
    long credited = 0;
    for (int k = 0; k < 6; ++k) {
      const int x0 = std::uniform_int_distribution<int>(0, 120)(rng);
      const int y0 = std::uniform_int_distribution<int>(0, 90)(rng);
      const int w = std::uniform_int_distribution<int>(1, 40)(rng);
      const int h = std::uniform_int_distribution<int>(1, 30)(rng);
      const Footprint f = rect(x0, x0 + w, y0, y0 + h, storage[k]);
      credited += countFootprint(mask, f, chain.data(), static_cast<int>(chain.size())).matched;
      chain.push_back(f);
      union_mask(cv::Rect(x0, y0, w, h)) = 255;
    }
    cv::Mat covered;
    cv::bitwise_and(union_mask, image, covered);
    ASSERT_EQ(credited, cv::countNonZero(covered)) << "trial " << trial;
  }
}

TEST(Likelihood, CountsAndRecountsMatchAPixelByPixelReferenceForOverlappingConvexFootprints) {
  // Random row spans (empty rows included) under up to 7 explained footprints covering the same
  // area, so every per-row case of the count (nothing, one, two and more explained) is exercised.
  std::mt19937 rng(17);
  cv::Mat image(90, 200, CV_8UC1);
  cv::randu(image, 0, 2);
  image *= 255;
  const SilhouetteMask mask(image);
  auto randomFootprint = [&](std::vector<RowSpan>& storage) {
    const int y0 = std::uniform_int_distribution<int>(0, 60)(rng);
    const int h = std::uniform_int_distribution<int>(1, 89 - y0)(rng);
    storage.resize(h);
    Footprint f{y0, y0 + h, 200, 0, storage.data()};
    const int centre = std::uniform_int_distribution<int>(40, 160)(rng);
    for (int r = 0; r < h; ++r) {
      int x0 = std::clamp(centre - std::uniform_int_distribution<int>(-5, 40)(rng), 0, 200);
      int x1 = std::clamp(centre + std::uniform_int_distribution<int>(-5, 40)(rng), 0, 200);
      if (x1 < x0 || std::uniform_int_distribution<int>(0, 9)(rng) == 0) x1 = x0;  // empty row
      storage[r] = {static_cast<int16_t>(x0), static_cast<int16_t>(x1)};
      if (x1 > x0) {
        f.xmin = std::min(f.xmin, x0);
        f.xmax = std::max(f.xmax, x1);
      }
    }
    if (f.xmin >= f.xmax) f.xmin = f.xmax = 0;
    return f;
  };
  auto inside = [](const Footprint& f, int x, int y) {
    return y >= f.y0 && y < f.y1 && x >= f.spans[y - f.y0].x0 && x < f.spans[y - f.y0].x1;
  };
  for (int trial = 0; trial < 300; ++trial) {
    const int n = std::uniform_int_distribution<int>(0, 7)(rng);
    std::vector<std::vector<RowSpan>> storage(n + 1);
    std::vector<Footprint> explained;
    for (int k = 0; k < n; ++k) explained.push_back(randomFootprint(storage[k]));
    const Footprint f = randomFootprint(storage[n]);
    PixelCounts expected;
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        if (!inside(f, x, y)) continue;
        const bool on = image.at<uint8_t>(y, x) != 0;
        bool before = false;
        for (const Footprint& e : explained) before = before || inside(e, x, y);
        ++expected.area;
        expected.outside += !on;
        expected.matched += on && !before;
      }
    }
    const PixelCounts got = countFootprint(mask, f, explained.data(), n);
    ASSERT_EQ(got.area, expected.area) << "trial " << trial;
    ASSERT_EQ(got.outside, expected.outside) << "trial " << trial;
    ASSERT_EQ(got.matched, expected.matched) << "trial " << trial;
    // Recounted from the footprint's counts over an empty chain: only the explained rows walked.
    const PixelCounts alone = countFootprint(mask, f, nullptr, 0);
    const PixelCounts recounted = recountFootprint(mask, f, alone, explained.data(), n);
    ASSERT_EQ(recounted.area, expected.area) << "trial " << trial;
    ASSERT_EQ(recounted.outside, expected.outside) << "trial " << trial;
    ASSERT_EQ(recounted.matched, expected.matched) << "trial " << trial;
  }
}

}  // namespace
}  // namespace mocap
