#include <iostream>
int main() { std::cerr << "tet2spline: under construction\n"; return 2; }
