"""mgdata.engine"""
