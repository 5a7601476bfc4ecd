// planner: the balance planner process (its binding: hpr/graph/bindings.hpp, PlannerBinding).
#include "hpr/graph/bindings.hpp"

int main(int argc, char** argv) { return hpr::graph::run_node<hpr::graph::PlannerBinding>(argc, argv); }
