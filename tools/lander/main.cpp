// The `lander` command line (placeholder entry point; subcommands land with sim/).
#include <iostream>
int main(int argc, char** argv) {
  std::cerr << "lander: no subcommands yet\n";
  return 2;
}
