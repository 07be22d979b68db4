"""mgdata.motion"""
