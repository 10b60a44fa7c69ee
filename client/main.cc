// texfree: command-line client of texfree-server.
#include <iostream>

#include "client/cli.h"

int main(int argc, char** argv) {
  return texfree::client::RunCli(argc, argv, std::cout, std::cerr);
}
