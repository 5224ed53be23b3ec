"""Operations: supervising the stack's processes, the demo stack, a trial driven through the API."""
