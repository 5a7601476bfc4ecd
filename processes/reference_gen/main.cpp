// reference_gen: the three-phase CAM reference generator process (its binding:
// hpr/graph/bindings.hpp, ReferenceGenBinding).
#include "hpr/graph/bindings.hpp"

int main(int argc, char** argv) { return hpr::graph::run_node<hpr::graph::ReferenceGenBinding>(argc, argv); }
