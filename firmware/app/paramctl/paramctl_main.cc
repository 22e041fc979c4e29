// mfns-paramctl: the parameter store on the flyer (paramctl.h).
#include <unistd.h>

#include <cstdio>

#include "firmware/app/paramctl/paramctl.h"

int main(int argc, char** argv) { return mfns::fw::RunParamctl(argc, argv, STDIN_FILENO, stdout, stderr); }
