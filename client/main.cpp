#include "stickslip/client/cli.h"

int main(int argc, char** argv) { return stickslip::client::run(argc, argv); }
