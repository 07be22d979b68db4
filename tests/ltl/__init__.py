"""Tests of ltl."""
