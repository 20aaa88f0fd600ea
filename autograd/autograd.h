// autograd.h — everything of the autograd layer in one include.
#pragma once
#include "autograd/gradcheck.h"
#include "autograd/no_grad.h"
#include "autograd/node.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_index.h"
#include "autograd/ops_join.h"
#include "autograd/ops_linalg.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_softmax.h"
#include "autograd/ops_unary.h"
#include "autograd/variable.h"
