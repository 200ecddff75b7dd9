// Board flags, each checked here so the error names the flag rather than a BoardSpec field.
#include "tracker/calibration/board_flags.h"

#include <sstream>
#include <stdexcept>

namespace mocap {

BoardSpec boardFromFlags(const Args& args, BoardSpec board) {
  if (args.has("board")) {
    const std::string type = args.text("board", "");
    if (type != "checkerboard" && type != "charuco")
      throw std::invalid_argument("--board '" + type + "': expected checkerboard or charuco");
    board.type = parseBoardType(type);
  }
  board.cols = static_cast<int>(args.integer("cols", board.cols, 3, 1000));
  board.rows = static_cast<int>(args.integer("rows", board.rows, 3, 1000));
  board.square = args.real("square", board.square, 1e-4, 10);
  std::ostringstream message;
  if (board.type == BoardType::kCheckerboard) {
    for (const char* flag : {"marker", "dictionary"})
      if (args.has(flag))
        throw std::invalid_argument(std::string("--") + flag +
                                    " applies to --board charuco only (a checkerboard has no "
                                    "markers)");
    if ((board.cols + board.rows) % 2 == 0) {
      message << "--cols " << board.cols << " --rows " << board.rows
              << ": a checkerboard needs cols + rows odd (e.g. 9x6), otherwise it looks the same "
                 "after a half turn and cameras could number its corners differently";
      throw std::invalid_argument(message.str());
    }
  } else {
    board.marker = args.real("marker", board.marker, 1e-4, 10);
    if (!(board.marker < board.square)) {
      message << "--marker " << board.marker << " must be smaller than --square " << board.square
              << " (each marker sits inside a white square; 0.75 of it is usual)";
      throw std::invalid_argument(message.str());
    }
    std::string dictionary = args.text("dictionary", board.dictionary);
    if (dictionary.rfind("DICT_", 0) == 0) dictionary = dictionary.substr(5);
    if (!isArucoDictionary(dictionary))
      throw std::invalid_argument("--dictionary '" + args.text("dictionary", "") +
                                  "': unknown ArUco dictionary (expected NXN_M with N 4-7 and M "
                                  "50, 100, 250 or 1000, e.g. 5X5_100)");
    board.dictionary = dictionary;
    const int needed = board.cols * board.rows / 2;
    if (needed > arucoDictionarySize(dictionary)) {
      message << "--dictionary " << dictionary << " holds " << arucoDictionarySize(dictionary)
              << " markers but a " << board.cols << "x" << board.rows << " ChArUco board needs "
              << needed << ": use a larger dictionary";
      throw std::invalid_argument(message.str());
    }
  }
  validateBoard(board);
  return board;
}

}  // namespace mocap
