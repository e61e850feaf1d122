// A downstream program: builds a neighbour list through the installed / added mpskit and checks it.
#include <mpskit/mpskit.hpp>

#include <iostream>

int main() {
  mpskit::points<2> x(2, 4);
  x << 0.0, 1.0, 0.0, 5.0,  //
      0.0, 0.0, 1.0, 5.0;
  mpskit::search::neighbour_list<2> list;
  list.build(mpskit::exec::seq{}, x, mpskit::search::uniform_radius{1.5});
  const bool ok = list.count(0) == 2 && list.count(3) == 0;
  std::cout << "consumer: particle 0 has " << list.count(0) << " neighbours (expected 2)\n";
  return ok ? 0 : 1;
}
