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

// ChArUco corner refinement (see refineCharucoCorners): the smallest half window, and the
// farthest a refined corner may move from where the markers put it (those are within a pixel).
constexpr int kMinCharucoWindow = 2;
constexpr double kMaxCharucoShiftPx = 1.0;

// A refined corner farther than this from where its neighbours put it is refined again from
// there (see reseedStrayCorners).
constexpr double kMaxStrayPx = 0.5;

// Where corner `i` of a w x h grid should be according to its neighbours up to two squares away:
// a homography fitted to them (over that range the lens distortion bends the grid by hundredths of
// a pixel).
cv::Point2f predictFromNeighbours(const std::vector<cv::Point2f>& corners, int w, int h, int i) {
  const int col = i % w, row = i / w;
  std::vector<cv::Point2f> grid, image;
  for (int r = std::max(0, row - 2); r <= std::min(h - 1, row + 2); ++r)
    for (int c = std::max(0, col - 2); c <= std::min(w - 1, col + 2); ++c)
      if (r != row || c != col) {
        grid.emplace_back(static_cast<float>(c), static_cast<float>(r));
        image.push_back(corners[r * w + c]);
      }
  const cv::Mat homography = cv::findHomography(grid, image, 0);
  if (homography.empty()) return corners[i];
  std::vector<cv::Point2f> predicted;
  cv::perspectiveTransform(std::vector<cv::Point2f>{cv::Point2f(col, row)}, predicted, homography);
  return predicted[0];
}

// The classic finder places the board's outer corners from eroded quads, several pixels off on
// oblique views, and cornerSubPix does not pull a point that sits on a straight edge along that
// edge: such a corner stays off. Worst first (a stray corner also skews its neighbours'
// predictions), each corner farther than kMaxStrayPx from its predicted place is refined again
// starting there. False if one still disagrees after that.
bool reseedStrayCorners(const cv::Mat& gray, std::vector<cv::Point2f>& corners, int w, int h,
                        int half, const cv::TermCriteria& criteria) {
  std::vector<bool> reseeded(corners.size(), false);
  for (std::size_t pass = 0; pass < corners.size(); ++pass) {
    int worst = -1;
    double worst_distance = kMaxStrayPx;
    cv::Point2f worst_prediction;
    for (int i = 0; i < static_cast<int>(corners.size()); ++i) {
      const cv::Point2f predicted = predictFromNeighbours(corners, w, h, i);
      const double distance = cv::norm(predicted - corners[i]);
      if (distance > worst_distance) {
        worst = i;
        worst_distance = distance;
        worst_prediction = predicted;
      }
    }
    if (worst < 0) return true;
    if (reseeded[worst]) return false;
    reseeded[worst] = true;
    std::vector<cv::Point2f> corner = {worst_prediction};
    cv::cornerSubPix(gray, corner, cv::Size(half, half), cv::Size(-1, -1), criteria);
    corners[worst] = corner[0];
  }
  return true;
}

// interpolateCornersCharuco (OpenCV 4.6) returns corners about half a pixel off on these boards
// (the marker corners it starts from are whole pixels and its own refinement barely moves them).
// Each corner is refined again with the largest window that stays off the markers beside it: a
// marker edge inside the window pulls the corner toward it. Corners without room for a 5x5 window
// (small or oblique boards: the marker almost touches the corner), and corners that do not
// converge near where the markers put them, are dropped: on such views they were 1-3 px off.
void refineCharucoCorners(const cv::Mat& gray,
                          const std::vector<std::vector<cv::Point2f>>& marker_corners,
                          std::vector<cv::Point2f>& corners, std::vector<int>& ids) {
  const cv::TermCriteria criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001);
  std::vector<cv::Point2f> kept_corners;
  std::vector<int> kept_ids;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    // The window (a square of half side `half`) holds a marker corner when both offsets are
    // within `half`; one pixel more keeps the blurred marker edge out.
    double clear = 1e9;
    for (const auto& marker : marker_corners)
      for (const cv::Point2f& m : marker)
        clear = std::min(clear, static_cast<double>(std::max(std::abs(m.x - corners[i].x),
                                                             std::abs(m.y - corners[i].y))));
    const int half = std::min(static_cast<int>(clear - 1), 11);
    if (half < kMinCharucoWindow) continue;
    std::vector<cv::Point2f> corner = {corners[i]};
    cv::cornerSubPix(gray, corner, cv::Size(half, half), cv::Size(-1, -1), criteria);
    // cornerSubPix hands back its start point when it diverges.
    const double moved = cv::norm(corner[0] - corners[i]);
    if (moved == 0 || moved > kMaxCharucoShiftPx) continue;
    kept_corners.push_back(corner[0]);
    kept_ids.push_back(ids[i]);
  }
  corners = std::move(kept_corners);
  ids = std::move(kept_ids);
}

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

bool isArucoDictionary(const std::string& name) { return dictionaries().count(name) > 0; }

int arucoDictionarySize(const std::string& name) {
  if (!isArucoDictionary(name)) return 0;
  return std::stoi(name.substr(name.find('_') + 1));
}

std::string detectionProblem(const BoardSpec& board, const BoardDetection& detection) {
  const int n = static_cast<int>(detection.ids.size());
  if (n != static_cast<int>(detection.pixels.size()))
    return std::to_string(n) + " corner ids for " + std::to_string(detection.pixels.size()) +
           " corner positions";
  if (n < kMinBoardCorners)
    return "only " + std::to_string(n) + " board corners (need " +
           std::to_string(kMinBoardCorners) + ")";
  std::vector<bool> seen(board.cornerCount(), false);
  for (int id : detection.ids) {
    if (id < 0 || id >= board.cornerCount())
      return "corner id " + std::to_string(id) + " is not on a " + std::to_string(board.cols) +
             "x" + std::to_string(board.rows) + " board (wrong board size?)";
    if (seen[id]) return "corner id " + std::to_string(id) + " found twice";
    seen[id] = true;
  }
  // Board grid coordinates are integers, so collinearity is exact: every corner on the line
  // through the first two.
  const int w = board.innerCols();
  const int c0 = detection.ids[0] % w, r0 = detection.ids[0] / w;
  const int dc = detection.ids[1] % w - c0, dr = detection.ids[1] / w - r0;
  for (int id : detection.ids)
    if ((id % w - c0) * dr - (id / w - r0) * dc != 0) return "";
  return "all " + std::to_string(n) +
         " corners lie on one line of the board, which does not fix its pose";
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
    if (markers > arucoDictionarySize(board.dictionary))
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
  // The refinement window must stay inside one square, along rows and along columns: an oblique
  // board is foreshortened in one direction only, and a window reaching the next corner there
  // pulls the refined corner pixels away from the true one.
  double spacing = 1e9;
  for (int i = 0; i < static_cast<int>(corners.size()); ++i) {
    if ((i + 1) % w) spacing = std::min(spacing, cv::norm(corners[i + 1] - corners[i]));
    if (i + w < static_cast<int>(corners.size()))
      spacing = std::min(spacing, cv::norm(corners[i + w] - corners[i]));
  }
  const int half = std::clamp(static_cast<int>(spacing * 0.4), 2, 11);
  const cv::TermCriteria criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001);
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1), criteria);
  if (!reseedStrayCorners(gray, corners, w, h, half, criteria)) {
    why = "checkerboard corners inconsistent with their neighbours (blurred or occluded board?)";
    return false;
  }

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
  refineCharucoCorners(gray, marker_corners, corners, ids);
  BoardDetection found{std::move(ids), std::move(corners)};
  const std::string problem = detectionProblem(board_, found);
  if (!problem.empty()) {
    why = "ChArUco board (" + std::to_string(marker_ids.size()) + " markers decoded): " + problem;
    return false;
  }
  detection = std::move(found);
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
