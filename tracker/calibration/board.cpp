// Board geometry, detection (OpenCV's checkerboard finder, or ArUco markers interpolated to ChArUco
// corners) and rendering.
#include "tracker/calibration/board.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap {

namespace {

const std::map<std::string, cv::aruco::PREDEFINED_DICTIONARY_NAME>& dictionaries() {
  static const std::map<std::string, cv::aruco::PREDEFINED_DICTIONARY_NAME> names = {
      {"4X4_50", cv::aruco::DICT_4X4_50},     {"4X4_100", cv::aruco::DICT_4X4_100},
      {"4X4_250", cv::aruco::DICT_4X4_250},   {"4X4_1000", cv::aruco::DICT_4X4_1000},
      {"5X5_50", cv::aruco::DICT_5X5_50},     {"5X5_100", cv::aruco::DICT_5X5_100},
      {"5X5_250", cv::aruco::DICT_5X5_250},   {"5X5_1000", cv::aruco::DICT_5X5_1000},
      {"6X6_50", cv::aruco::DICT_6X6_50},     {"6X6_100", cv::aruco::DICT_6X6_100},
      {"6X6_250", cv::aruco::DICT_6X6_250},   {"6X6_1000", cv::aruco::DICT_6X6_1000},
      {"7X7_50", cv::aruco::DICT_7X7_50},     {"7X7_100", cv::aruco::DICT_7X7_100},
      {"7X7_250", cv::aruco::DICT_7X7_250},   {"7X7_1000", cv::aruco::DICT_7X7_1000}};
  return names;
}

cv::Ptr<cv::aruco::CharucoBoard> makeCharuco(const BoardSpec& board) {
  return cv::aruco::CharucoBoard::create(
      board.cols, board.rows, static_cast<float>(board.square), static_cast<float>(board.marker),
      cv::aruco::getPredefinedDictionary(dictionaries().at(board.dictionary)));
}

// Fewer ChArUco corners than this do not constrain a pose reliably.
constexpr int kMinCharucoCorners = 6;

}  // namespace

cv::Point3f BoardSpec::corner(int id) const {
  return {static_cast<float>((id % innerCols()) * square),
          static_cast<float>((id / innerCols()) * square), 0.0f};
}

BoardType parseBoardType(const std::string& name) {
  if (name == "checkerboard") return BoardType::kCheckerboard;
  if (name == "charuco") return BoardType::kCharuco;
  throw std::invalid_argument("board: unknown type '" + name + "' (expected checkerboard or charuco)");
}

void validateBoard(const BoardSpec& board) {
  if (board.cols < 3 || board.rows < 3)
    throw std::invalid_argument("board: needs at least 3x3 squares, got " +
                                std::to_string(board.cols) + "x" + std::to_string(board.rows));
  if (!(board.square > 0)) throw std::invalid_argument("board: square size must be positive");
  if (board.type == BoardType::kCheckerboard && (board.cols + board.rows) % 2 == 0)
    throw std::invalid_argument(
        "board: a checkerboard needs an odd total of cols + rows (e.g. 9x6): otherwise it looks "
        "the same after a half turn and cameras could number its corners differently");
  if (board.type == BoardType::kCharuco) {
    if (!(board.marker > 0 && board.marker < board.square))
      throw std::invalid_argument("board: marker size must be positive and below the square size");
    auto it = dictionaries().find(board.dictionary);
    if (it == dictionaries().end())
      throw std::invalid_argument("board: unknown ArUco dictionary '" + board.dictionary + "'");
    const int markers = board.cols * board.rows / 2;
    const int available = std::stoi(board.dictionary.substr(board.dictionary.find('_') + 1));
    if (markers > available)
      throw std::invalid_argument("board: " + std::to_string(markers) + " markers do not fit in " +
                                  "dictionary " + board.dictionary);
  }
}

BoardDetector::BoardDetector(const BoardSpec& board) : board_(board) { validateBoard(board_); }

bool BoardDetector::detect(const cv::Mat& image, BoardDetection& detection,
                           std::string& why) const {
  detection.ids.clear();
  detection.pixels.clear();
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    why = "not an 8-bit gray or colour image";
    return false;
  }
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return board_.type == BoardType::kCheckerboard ? detectCheckerboard(gray, detection, why)
                                                 : detectCharuco(gray, detection, why);
}

bool BoardDetector::detectCheckerboard(const cv::Mat& gray, BoardDetection& detection,
                                       std::string& why) const {
  const int w = board_.innerCols(), h = board_.innerRows();
  std::vector<cv::Point2f> corners;
  // The classic finder without adaptive thresholding takes milliseconds (with it, seconds on some
  // noisy images); the sector-based finder is slower but copes with oblique views.
  if (!cv::findChessboardCorners(gray, cv::Size(w, h), corners, 0) &&
      !cv::findChessboardCornersSB(gray, cv::Size(w, h), corners, cv::CALIB_CB_NORMALIZE_IMAGE)) {
    why = "no complete " + std::to_string(board_.cols) + "x" + std::to_string(board_.rows) +
          " checkerboard found";
    return false;
  }
  // The refinement window must stay inside one square.
  double spacing = 1e9;
  for (int i = 0; i + 1 < static_cast<int>(corners.size()); ++i)
    if ((i + 1) % w) spacing = std::min(spacing, cv::norm(corners[i + 1] - corners[i]));
  const int half = std::clamp(static_cast<int>(spacing * 0.4), 2, 11);
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001));

  // Seen from the front, the board's x and y axes keep their orientation in the image; a mirrored
  // order means the finder walked the rows backwards.
  const cv::Point2f ax = corners[1] - corners[0], ay = corners[w] - corners[0];
  if (ax.x * ay.y - ax.y * ay.x < 0)
    for (int r = 0; r < h; ++r) std::reverse(corners.begin() + r * w, corners.begin() + (r + 1) * w);
  // The square between the first four corners is black (board square (1, 1)); if it is the
  // lighter one, the finder started from the opposite corner: a half turn.
  auto squareMean = [&](int id) {
    std::vector<cv::Point> quad = {corners[id], corners[id + 1], corners[id + w + 1],
                                   corners[id + w]};
    cv::Mat mask = cv::Mat::zeros(gray.size(), CV_8UC1);
    cv::fillConvexPoly(mask, quad, 255);
    return cv::mean(gray, mask)[0];
  };
  if (squareMean(0) > squareMean(1)) std::reverse(corners.begin(), corners.end());

  detection.pixels = std::move(corners);
  detection.ids.resize(detection.pixels.size());
  for (int i = 0; i < static_cast<int>(detection.ids.size()); ++i) detection.ids[i] = i;
  return true;
}

bool BoardDetector::detectCharuco(const cv::Mat& gray, BoardDetection& detection,
                                  std::string& why) const {
  const cv::Ptr<cv::aruco::CharucoBoard> charuco = makeCharuco(board_);
  std::vector<int> marker_ids;
  std::vector<std::vector<cv::Point2f>> marker_corners;
  cv::aruco::detectMarkers(gray, charuco->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) {
    why = "no ArUco marker of dictionary " + board_.dictionary + " found";
    return false;
  }
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, charuco, corners, ids);
  if (static_cast<int>(ids.size()) < kMinCharucoCorners) {
    why = "only " + std::to_string(ids.size()) + " ChArUco corners found (need " +
          std::to_string(kMinCharucoCorners) + ")";
    return false;
  }
  detection.ids = std::move(ids);
  detection.pixels = std::move(corners);
  return true;
}

cv::Mat renderBoardImage(const BoardSpec& board, int pixels_per_square, cv::Matx33d& to_board) {
  validateBoard(board);
  const int pps = pixels_per_square;
  const cv::Size size((board.cols + 2) * pps, (board.rows + 2) * pps);
  cv::Mat image(size, CV_8UC1, cv::Scalar(255));
  if (board.type == BoardType::kCheckerboard) {
    // Square (i, j) is black when i + j is even.
    for (int j = 0; j < board.rows; ++j)
      for (int i = (j % 2); i < board.cols; i += 2)
        image(cv::Rect((i + 1) * pps, (j + 1) * pps, pps, pps)).setTo(0);
  } else {
    cv::Mat inner = image(cv::Rect(pps, pps, board.cols * pps, board.rows * pps));
    cv::Mat drawn;
    makeCharuco(board)->draw(inner.size(), drawn, 0, 1);
    drawn.copyTo(inner);
  }
  // Pixel centre (u, v) -> board metres; the first inner corner sits at (2 * pps, 2 * pps) edges.
  const double s = board.square / pps;
  const double offset = (0.5 / pps - 2.0) * board.square;
  to_board = cv::Matx33d(s, 0, offset, 0, s, offset, 0, 0, 1);
  return image;
}

}  // namespace mocap
