class MPCController: pass
