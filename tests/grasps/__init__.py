"""Tests of grasps."""
