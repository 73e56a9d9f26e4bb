#include "rayclass/cli/cli.h"

int main(int argc, char** argv) { return rayclass::cli::Main(argc, argv); }
