#include <iostream>
int main () { std::cout << "pclx consumer linked\n"; return 0; }
