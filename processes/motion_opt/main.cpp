// motion_opt: the CAM-based whole-body motion optimisation process (its binding:
// hpr/graph/bindings.hpp, MotionOptBinding).
#include "hpr/graph/bindings.hpp"

int main(int argc, char** argv) { return hpr::graph::run_node<hpr::graph::MotionOptBinding>(argc, argv); }
