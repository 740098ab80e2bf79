// crosslink: cross-validates the kinematics of planar linkages.
#include "app/commands.h"

int main(int argc, char** argv) {
  return crosslink::app::run_command_line(argc, argv);
}
