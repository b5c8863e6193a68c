/// Writes the synthetic planetary_vo-format dataset of synthetic_dataset.h into argv[1] (for the player
/// rostests).

#include <iostream>

#include "synthetic_dataset.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_player_test_dataset OUTPUT_DIR\n";
    return 2;
  }
  try {
    planetary_vo::test::writeSyntheticLanding(argv[1]);
  } catch (const std::exception& e) {
    std::cerr << "make_player_test_dataset: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
