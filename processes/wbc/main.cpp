// wbc: the passivity-based whole-body controller process (its binding: hpr/graph/bindings.hpp,
// WbcBinding).
#include "hpr/graph/bindings.hpp"

int main(int argc, char** argv) { return hpr::graph::run_node<hpr::graph::WbcBinding>(argc, argv); }
