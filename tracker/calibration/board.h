// Calibration boards: a plain checkerboard or a ChArUco board (checkerboard with ArUco markers in
// the white squares, so partial views still identify every corner), their corner detection in an
// image, and their rendering for simulated calibrations.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace mocap {

enum class BoardType { kCheckerboard, kCharuco };

struct BoardSpec {
  BoardType type = BoardType::kCheckerboard;
  int cols = 9;          // squares along the board's x axis
  int rows = 7;          // squares along its y axis
  double square = 0.04;  // square side, metres
  double marker = 0.03;  // ChArUco marker side, metres
  std::string dictionary = "4X4_250";  // ChArUco: ArUco dictionary name (4X4_50 ... 7X7_1000)

  int innerCols() const { return cols - 1; }
  int innerRows() const { return rows - 1; }
  int cornerCount() const { return innerCols() * innerRows(); }
  // Corner `id` (row-major over inner corners) in the board frame: x along cols, y along rows,
  // z into the board, origin at the first inner corner, metres.
  cv::Point3f corner(int id) const;
};

// Known ArUco dictionary names ("4X4_50" ... "7X7_1000") and how many markers each holds.
bool isArucoDictionary(const std::string& name);
int arucoDictionarySize(const std::string& name);

// Throws std::invalid_argument naming the bad field (sizes, marker >= square, unknown dictionary;
// a checkerboard must have cols + rows odd, else its corner order is ambiguous under a half turn).
void validateBoard(const BoardSpec& board);
BoardType parseBoardType(const std::string& name);  // "checkerboard" | "charuco"

struct BoardDetection {
  std::vector<int> ids;               // corner ids, see BoardSpec::corner
  std::vector<cv::Point2f> pixels;    // sub-pixel corner positions
};

// Fewest corners a view may have: fewer fix a board pose poorly.
inline constexpr int kMinBoardCorners = 6;

// Empty if `detection` can constrain a board pose; otherwise why not: fewer than
// kMinBoardCorners corners, ids repeated or not on the board, or every corner on one straight line
// of the board (a ChArUco board seen along one row, or mostly hidden).
std::string detectionProblem(const BoardSpec& board, const BoardDetection& detection);

class BoardDetector {
 public:
  explicit BoardDetector(const BoardSpec& board);  // validates the board
  // `image`: 8-bit gray or BGR. False with `why` set when no usable board is found.
  bool detect(const cv::Mat& image, BoardDetection& detection, std::string& why) const;
  const BoardSpec& board() const { return board_; }

 private:
  bool detectCheckerboard(const cv::Mat& gray, BoardDetection& detection, std::string& why) const;
  bool detectCharuco(const cv::Mat& gray, BoardDetection& detection, std::string& why) const;
  BoardSpec board_;
};

// The printed board as an image, `pixels_per_square` per square with a white margin of one square;
// `to_board` maps its pixel coordinates to board-frame metres (3x3, homogeneous).
cv::Mat renderBoardImage(const BoardSpec& board, int pixels_per_square, cv::Matx33d& to_board);

}  // namespace mocap
