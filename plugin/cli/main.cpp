#include <iostream>

#include "plugin/cli/cli.h"

int main(int argc, char** argv) {
  return radbake::runCommandLine(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
